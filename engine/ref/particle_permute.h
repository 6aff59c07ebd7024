#pragma once
// Reference of shaders/particle_permute.comp: slot q of the output takes particle order[q] (positions, features,
// original ids and material masks alike); the order becomes the identity.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::ref {

struct PermutedParticles {
  std::vector<glm::vec4> particles;
  std::vector<uint32_t> features, ids, order;
  std::vector<glm::uvec4> masks;
};

PermutedParticles particle_permute(const std::vector<uint32_t>& order, const std::vector<glm::vec4>& particles,
                                   const std::vector<uint32_t>& features, const std::vector<uint32_t>& ids,
                                   const std::vector<glm::uvec4>& masks);

}  // namespace cpmesh::ref
