#pragma once
// Reference of shaders/octree_moments.comp: per node (box min, min h), (box max, 0), (centre of mass, count).
#include <vector>

#include <glm/glm.hpp>

#include "ref/octree_build.h"

namespace cpmesh::ref {

std::vector<glm::vec4> octree_moments(const Octree& tree, const std::vector<uint32_t>& order,
                                      const std::vector<glm::vec4>& particles);

}  // namespace cpmesh::ref
