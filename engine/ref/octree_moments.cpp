#include "ref/octree_moments.h"

#include <algorithm>

namespace cpmesh::ref {

std::vector<glm::vec4> octree_moments(const Octree& t, const std::vector<uint32_t>& order,
                                      const std::vector<glm::vec4>& particles) {
  std::vector<glm::vec4> m(3 * t.nodes.size());
  for (int level = 21; level >= 0; --level) {
    const glm::uvec2 info = t.level_info[size_t(level)];
    for (uint32_t id = info.x; id < info.x + info.y; ++id) {
      const glm::uvec4 node = t.nodes[id];
      const uint32_t children = node.w & 0xffu;
      glm::vec3 lo(3.4e38f), hi(-3.4e38f), sum(0.0f);
      float min_h = 3.4e38f, total = 0.0f;
      if (children == 0) {
        const uint32_t count = std::min<uint32_t>(node.y, 4096);
        for (uint32_t k = 0; k < count; ++k) {
          const glm::vec4 p = particles[order[node.x + k]];
          lo = glm::min(lo, glm::vec3(p));
          hi = glm::max(hi, glm::vec3(p));
          min_h = std::min(min_h, p.w);
          sum += glm::vec3(p);
        }
        total = float(node.y);
        if (count > 0) sum /= float(count);
      } else {
        for (uint32_t c = 0; c < children; ++c) {
          const size_t child = node.z + c;
          lo = glm::min(lo, glm::vec3(m[3 * child]));
          hi = glm::max(hi, glm::vec3(m[3 * child + 1]));
          min_h = std::min(min_h, m[3 * child].w);
          sum += glm::vec3(m[3 * child + 2]) * m[3 * child + 2].w;
          total += m[3 * child + 2].w;
        }
        if (total > 0.0f) sum /= total;
      }
      m[3 * size_t(id)] = glm::vec4(lo, min_h);
      m[3 * size_t(id) + 1] = glm::vec4(hi, 0.0f);
      m[3 * size_t(id) + 2] = glm::vec4(sum, total);
    }
  }
  return m;
}

}  // namespace cpmesh::ref
