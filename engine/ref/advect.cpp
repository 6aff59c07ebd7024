#include "ref/advect.h"

#include <cmath>

namespace cpmesh::ref {

uint32_t advect(const fields::ClosestPointEmbedding& E, std::vector<glm::vec4>& particles,
                const std::vector<uint32_t>& features, const std::vector<glm::vec4>& walk, float alpha, float max_move) {
  uint32_t lost = 0;
  for (size_t i = 0; i < particles.size(); ++i) {
    if (E.features[features[i]].kind == fields::FeatureKind::quadruple_point) continue;
    const glm::vec4 p = particles[i];
    glm::vec3 step = -alpha * p.w * p.w * glm::vec3(walk[i]);
    const float len = glm::length(step), limit = max_move * p.w;
    if (len > limit) step *= limit / len;
    const CpResult cp = cp_lookup(E, glm::vec3(p) + step, features[i]);
    const glm::vec4& q = cp.value;
    const bool finite = std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z) && std::isfinite(q.w);
    if (!cp.valid || !finite || q.w <= 0.0f) {  // as advect.comp
      ++lost;
      continue;
    }
    particles[i] = cp.value;
  }
  return lost;
}

}  // namespace cpmesh::ref
