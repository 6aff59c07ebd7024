#pragma once
// Reference of the closest point lookup (shaders/shared/cp_lookup.glsl, shaders/cp_lookup.comp): WENO4 interpolation
// (Macdonald & Ruuth 2008) of the closest points stored on the embedding's fine grid, tensor-product over a 4x4x4
// stencil, component by component, in float32 like the shader. No iterative search.
// Where the stencil holds closest points of two sheets or curves of one feature (the two sides of a one-voxel sheet,
// the two triple curves where it ends on a layer), the blend lies between them, off the feature, and a particle
// reprojected there drifts to the other sheet within a few steps (docs/design.md, "Closest points on both sides of a
// thin sheet"). So the lookup returns, of the WENO4 blend and the eight tensor products of one-sided quadratics
// (WENO4's two candidates, one side per axis), the one nearest the query point: the true closest point is the nearest
// point of the feature, and a candidate whose samples keep to one sheet lies on it. A quadratic replaces the blend only when it
// lies kBlendMargin voxel nearer: on a smooth sheet all nine agree to the interpolation's accuracy, and switching
// among them there made the lookup jitter (the wedge ball's advection then never met its stop rule in a round).
#include <cstdint>

#include <glm/glm.hpp>

#include "fields/closest_point_embedding.h"

namespace cpmesh::ref {

constexpr float kBlendMargin = 0.005f;  // voxels (of the smallest spacing)

struct CpResult {
  glm::vec4 value{0.0f};  // closest point (local coordinates) in xyz, the fine grid's w (sizing) in w
  bool valid = false;     // false when part of the stencil lies outside the feature's band
};

// One-dimensional WENO4 interpolation of f(-1), f(0), f(1), f(2) at t in [0, 1).
float weno4(float f0, float f1, float f2, float f3, float t);
// The lookup's step along one axis: weno4 of each component, the sizing (w) then clamped to its four samples' range.
// WENO4's quadratic pieces undershoot a valley one sample wide (4, 0.25, 0.25, 4 gives -0.22 at t = 1/2), and
// where thin layers make such sizing valleys the lookup gave particles a negative h, which the advection turned
// into NaN positions (with stop 32's warm start: 18 particles of the 32^3 shells in the first run).
glm::vec4 weno4_lookup(const glm::vec4& f0, const glm::vec4& f1, const glm::vec4& f2, const glm::vec4& f3, float t);

CpResult cp_lookup(const fields::ClosestPointEmbedding& embedding, const glm::vec3& local, uint32_t feature);

}  // namespace cpmesh::ref
