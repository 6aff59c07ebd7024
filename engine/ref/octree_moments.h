#pragma once
// Reference of shaders/octree_moments.comp: per node (box min, min h), (box max, 0), (centre of mass, count),
// (AND of the particles' feature masks as two float-bit words, 0, 0).
#include <vector>

#include <glm/glm.hpp>

#include "ref/octree_build.h"

namespace cpmesh::ref {

std::vector<glm::vec4> octree_moments(const Octree& tree, const std::vector<uint32_t>& order,
                                      const std::vector<glm::vec4>& particles, const std::vector<uint32_t>& features,
                                      const std::vector<uint64_t>& feature_masks);

}  // namespace cpmesh::ref
