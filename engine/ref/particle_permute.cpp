#include "ref/particle_permute.h"

namespace cpmesh::ref {

PermutedParticles particle_permute(const std::vector<uint32_t>& order, const std::vector<glm::vec4>& particles,
                                   const std::vector<uint32_t>& features, const std::vector<uint32_t>& ids,
                                   const std::vector<glm::uvec4>& masks) {
  PermutedParticles out;
  for (uint32_t q = 0; q < uint32_t(order.size()); ++q) {
    out.particles.push_back(particles[order[q]]);
    out.features.push_back(features[order[q]]);
    out.ids.push_back(ids[order[q]]);
    out.masks.push_back(masks[order[q]]);
    out.order.push_back(q);
  }
  return out;
}

}  // namespace cpmesh::ref
