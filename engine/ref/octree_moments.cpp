#include "ref/octree_moments.h"

#include <algorithm>

#include <glm/gtc/packing.hpp>

namespace cpmesh::ref {

std::vector<glm::vec4> octree_moments(const Octree& t, const std::vector<uint32_t>& order,
                                      const std::vector<glm::vec4>& particles, const std::vector<uint32_t>& features,
                                      const std::vector<fields::MaterialSet>& masks, bool exact_sets) {
  std::vector<glm::vec4> m(4 * t.nodes.size());
  for (int level = 21; level >= 0; --level) {
    const glm::uvec2 info = t.level_info[size_t(level)];
    for (uint32_t id = info.x; id < info.x + info.y; ++id) {
      const glm::uvec4 node = t.nodes[id];
      const uint32_t children = node.w & 0xffu;
      glm::vec3 lo(3.4e38f), hi(-3.4e38f), sum(0.0f);
      float min_h = 3.4e38f, total = 0.0f;
      fields::MaterialSet and_mask;
      uint64_t and_bits = ~uint64_t(0);
      if (children == 0) {
        const uint32_t count = std::min<uint32_t>(node.y, 4096);
        for (uint32_t k = 0; k < count; ++k) {
          const fields::MaterialSet mine = masks[features[order[node.x + k]]];
          and_mask = k == 0 ? mine : and_mask.common(mine);
          and_bits &= mine.mask64();
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
          lo = glm::min(lo, glm::vec3(m[4 * child]));
          hi = glm::max(hi, glm::vec3(m[4 * child + 1]));
          min_h = std::min(min_h, m[4 * child].w);
          sum += glm::vec3(m[4 * child + 2]) * m[4 * child + 2].w;
          total += m[4 * child + 2].w;
          const glm::uvec4 words = glm::floatBitsToUint(m[4 * child + 3]);
          and_bits &= uint64_t(words.x) | uint64_t(words.y) << 32;
          const auto child_set = fields::MaterialSet::from_packed(uint64_t(words.z) | uint64_t(words.w) << 32);
          and_mask = c == 0 ? child_set : and_mask.common(child_set);
        }
        if (total > 0.0f) sum /= total;
      }
      m[4 * size_t(id)] = glm::vec4(lo, min_h);
      m[4 * size_t(id) + 1] = glm::vec4(hi, 0.0f);
      m[4 * size_t(id) + 2] = glm::vec4(sum, total);
      const uint64_t set = exact_sets ? and_mask.packed() : 0;
      m[4 * size_t(id) + 3] = glm::uintBitsToFloat(
          glm::uvec4(uint32_t(and_bits), uint32_t(and_bits >> 32), uint32_t(set), uint32_t(set >> 32)));
    }
  }
  return m;
}

}  // namespace cpmesh::ref
