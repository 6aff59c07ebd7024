#include "ref/morton_codes.h"

#include <algorithm>
#include <cmath>

namespace cpmesh::ref {

namespace {
uint64_t spread21(uint32_t v) {
  uint64_t r = 0;
  for (int i = 0; i < 21; ++i) r |= uint64_t((v >> i) & 1u) << (3 * i);
  return r;
}
}  // namespace

uint64_t morton_code(const glm::vec3& p, const glm::vec3& box_min, const glm::vec3& scale) {
  uint32_t c[3];
  for (int a = 0; a < 3; ++a) {
    const float q = std::floor((p[a] - box_min[a]) * scale[a]);  // float32, as in the shader
    c[a] = uint32_t(std::clamp(q, 0.0f, 2097151.0f));
  }
  return spread21(c[0]) | (spread21(c[1]) << 1) | (spread21(c[2]) << 2);
}

std::vector<uint64_t> morton_codes(const std::vector<glm::vec4>& positions, const glm::vec3& box_min,
                                   const glm::vec3& scale) {
  std::vector<uint64_t> keys(positions.size());
  for (size_t i = 0; i < positions.size(); ++i) keys[i] = morton_code(glm::vec3(positions[i]), box_min, scale);
  return keys;
}

}  // namespace cpmesh::ref
