#pragma once
// Reference of the tree walk (shaders/tree_walk.comp): the cotangent energy and its gradient by brute force over
// all pairs, with the same interaction rule (j's feature materials include i's) and the same float32 formulas.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::ref {

// particles: xyz position, w sizing h. features[i] indexes feature_masks (material sets as 64-bit masks).
// Returns per particle (gradient of E_i wrt p_i, E_i).
std::vector<glm::vec4> particle_energy(const std::vector<glm::vec4>& particles, const std::vector<uint32_t>& features,
                                       const std::vector<uint64_t>& feature_masks);

}  // namespace cpmesh::ref
