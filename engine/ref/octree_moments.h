#pragma once
// Reference of shaders/octree_moments.comp: per node (box min, min h), (box max, 0), (centre of mass, count),
// (the AND of the particles' material masks (MaterialSet::mask64) as two float-bit words, then with exact_sets the
// intersection of their sets (MaterialSet::common) as two more, else 0, 0).
#include <vector>

#include <glm/glm.hpp>

#include "fields/material_set.h"
#include "ref/octree_build.h"

namespace cpmesh::ref {

std::vector<glm::vec4> octree_moments(const Octree& tree, const std::vector<uint32_t>& order,
                                      const std::vector<glm::vec4>& particles, const std::vector<uint32_t>& features,
                                      const std::vector<fields::MaterialSet>& feature_masks, bool exact_sets);

}  // namespace cpmesh::ref
