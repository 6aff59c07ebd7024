#include "ref/octree_build.h"

namespace cpmesh::ref {

Octree build_octree(const std::vector<uint64_t>& keys, uint32_t leaf_size, uint32_t max_level) {
  Octree t;
  const uint32_t n = uint32_t(keys.size());
  t.nodes.push_back(glm::uvec4(0, n, 0, 0));
  t.level_info.assign(22, glm::uvec2(0));
  t.level_info[0] = glm::uvec2(0, 1);
  for (uint32_t level = 0; level < max_level && level < 21; ++level) {
    const glm::uvec2 here = t.level_info[level];
    const uint32_t base = here.x + here.y;
    uint32_t count = 0;
    const int shift = 63 - 3 * int(level + 1);
    for (uint32_t p = here.x; p < here.x + here.y; ++p) {
      const glm::uvec4 parent = t.nodes[p];  // a copy: push_back below may move the array
      if (parent.y <= leaf_size) continue;
      const uint32_t first = base + count;
      for (uint32_t i = parent.x; i < parent.x + parent.y;) {
        uint32_t j = i + 1;
        while (j < parent.x + parent.y && (keys[j] >> shift) == (keys[i] >> shift)) ++j;
        t.nodes.push_back(glm::uvec4(i, j - i, 0, (level + 1) << 8));
        ++count;
        i = j;
      }
      t.nodes[p] = glm::uvec4(t.nodes[p].x, t.nodes[p].y, first, (level << 8) | (base + count - first));
    }
    t.level_info[level + 1] = glm::uvec2(base, count);
  }
  return t;
}

}  // namespace cpmesh::ref
