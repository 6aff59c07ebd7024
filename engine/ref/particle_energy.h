#pragma once
// Reference of the tree walk (shaders/tree_walk.comp): the cotangent energy and its gradient by brute force over
// all pairs, with the same interaction rule (j's feature materials include i's) and the same float32 formulas.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "fields/material_set.h"

namespace cpmesh::ref {

// particles: xyz position, w sizing h. features[i] indexes feature_masks (material sets as 64-bit masks).
// Returns per particle (gradient of E_i wrt p_i, E_i).
std::vector<glm::vec4> particle_energy(const std::vector<glm::vec4>& particles, const std::vector<uint32_t>& features,
                                       const std::vector<fields::MaterialSet>& feature_masks);

// Reference of the Verlet neighbour lists (shaders/tree_walk.comp with NEIGHBOUR_LIST): for each i, the j != i whose
// feature bounds i's (the same rule) with |p_i - p_j| < 2 cos(pi/6) min(h_i, h_j) (1 + skin), ascending (the GPU
// stores them in walk order).
std::vector<std::vector<uint32_t>> neighbour_lists(const std::vector<glm::vec4>& particles,
                                                   const std::vector<uint32_t>& features,
                                                   const std::vector<fields::MaterialSet>& feature_masks, float skin);

// Reference of shaders/neighbour_drift.comp: max over i of |p_i - a_i| / a_i.w.
float neighbour_drift(const std::vector<glm::vec4>& particles, const std::vector<glm::vec4>& anchors);

}  // namespace cpmesh::ref
