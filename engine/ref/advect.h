#pragma once
// Reference of shaders/advect.comp: one advection step of every particle, with ref::cp_lookup for the reprojection.
#include <cstdint>
#include <vector>

#include "ref/cp_lookup.h"

namespace cpmesh::ref {

// particles (xyz, h) are updated in place; walk[i] = (gradient, E_i). Returns the number of particles whose moved
// position left their feature's band (they stay put).
uint32_t advect(const fields::ClosestPointEmbedding& embedding, std::vector<glm::vec4>& particles,
                const std::vector<uint32_t>& features, const std::vector<glm::vec4>& walk, float alpha, float max_move);

}  // namespace cpmesh::ref
