#pragma once
// The sizing field h (seed paper Sec. 3.1; Meyer et al.): the target particle spacing on the interfaces, from the
// local feature size LFS = min(radius of curvature, distance to the medial axis on either side, radius of curvature
// of the triple curves), times a density factor, also bounded on triple curves by the chord error of their edges,
// clamped to [h_min, h_max], then graded so that
// h(x) <= h(y) + grading * |x - y| (Lipschitz limiting).
// Physical units. Computed for every fine point of the closest point embedding and stored in its w, so the
// particle system reads h with the same WENO4 lookup that gives the closest point.
#include <vector>

#include "fields/closest_point_embedding.h"

namespace cpmesh::fields {

struct SizingOptions {
  double density = 0.5;   // h = density * LFS
  double h_min = 0.0;     // physical; 0 = 0.25 voxel (smallest spacing)
  double h_max = 0.0;     // physical; 0 = 4 voxels
  double grading = 0.5;   // Lipschitz constant of h
  double curve_chord = 0.2;  // voxels: along a triple curve, h also keeps the mesh edge between neighbouring curve
                             // particles this close to the curve (sizing_field.cpp; 0: off)
};

struct SizingStats {
  double h_min = 0, h_max = 0, h_mean = 0;
  size_t curvature_limited = 0, thickness_limited = 0, clamped = 0;  // which bound set h, per interface block
  size_t curve_limited = 0;  // curve blocks whose curve's own curvature lowered their cell's h
};

// Fills embedding.fine[*].w with h and returns statistics.
SizingStats compute_sizing_field(const IndicatorFields& fields, ClosestPointEmbedding& embedding,
                                 const SizingOptions& options = {});

}  // namespace cpmesh::fields
