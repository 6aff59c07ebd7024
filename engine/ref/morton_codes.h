#pragma once
// Reference of shaders/morton_codes.comp: 63-bit Morton keys (21 bits per axis) of positions in a box, bit-exact.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::ref {

// scale = 2^21 / box extent per axis; positions outside the box are clamped to its faces.
uint64_t morton_code(const glm::vec3& position, const glm::vec3& box_min, const glm::vec3& scale);
std::vector<uint64_t> morton_codes(const std::vector<glm::vec4>& positions, const glm::vec3& box_min,
                                   const glm::vec3& scale);

}  // namespace cpmesh::ref
