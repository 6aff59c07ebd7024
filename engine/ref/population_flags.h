#pragma once
// Reference of shaders/population_flags.comp (same float arithmetic): add/delete flags and per-feature sums.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::ref {

// flags: 0, 1 (delete: E > delete_factor ideal), 2 (add: E < add_factor ideal); counters: delete count, add count,
// then per feature the fixed-point sum of min(E / ideal, 16) x 64 (rounded) and the particle count.
void population_flags(const std::vector<glm::vec4>& walk, const std::vector<uint32_t>& features,
                      const std::vector<float>& ideals, float delete_factor, float add_factor,
                      std::vector<uint32_t>& flags, std::vector<uint32_t>& counters);

}  // namespace cpmesh::ref
