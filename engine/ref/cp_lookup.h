#pragma once
// Reference of the closest point lookup (shaders/shared/cp_lookup.glsl, shaders/cp_lookup.comp): WENO4 interpolation
// (Macdonald & Ruuth 2008) of the closest points stored on the embedding's fine grid, tensor-product over a 4x4x4
// stencil, component by component, in float32 like the shader. No iterative search.
#include <cstdint>

#include <glm/glm.hpp>

#include "fields/closest_point_embedding.h"

namespace cpmesh::ref {

struct CpResult {
  glm::vec4 value{0.0f};  // closest point (local coordinates) in xyz, the fine grid's w (sizing) in w
  bool valid = false;     // false when part of the stencil lies outside the feature's band
};

// One-dimensional WENO4 interpolation of f(-1), f(0), f(1), f(2) at t in [0, 1).
float weno4(float f0, float f1, float f2, float f3, float t);

CpResult cp_lookup(const fields::ClosestPointEmbedding& embedding, const glm::vec3& local, uint32_t feature);

}  // namespace cpmesh::ref
