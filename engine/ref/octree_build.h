#pragma once
// Reference of the GPU octree build (shaders/octree_split.comp, octree_level.comp, octree_children.comp): the same
// node array from Morton-sorted 63-bit keys, built level by level.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::ref {

struct Octree {
  // Node: (start, count, first_child, level << 8 | child_count); the nodes of a level are consecutive, in particle
  // order, levels one after another from the root at 0. A node is a leaf when it has leaf_size particles or fewer,
  // or is at level max_level (21: the keys' resolution).
  std::vector<glm::uvec4> nodes;
  std::vector<glm::uvec2> level_info;  // (first node, node count) per level 0..21
};

Octree build_octree(const std::vector<uint64_t>& sorted_keys, uint32_t leaf_size, uint32_t max_level = 21);

}  // namespace cpmesh::ref
