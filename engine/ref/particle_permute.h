#pragma once
// Reference of shaders/particle_permute.comp: slot q of the output takes particle order[q] (positions, features and
// original ids alike); the order becomes the identity.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::ref {

struct PermutedParticles {
  std::vector<glm::vec4> particles;
  std::vector<uint32_t> features, ids, order;
};

PermutedParticles particle_permute(const std::vector<uint32_t>& order, const std::vector<glm::vec4>& particles,
                                   const std::vector<uint32_t>& features, const std::vector<uint32_t>& ids);

}  // namespace cpmesh::ref
