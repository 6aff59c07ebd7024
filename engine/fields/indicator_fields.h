#pragma once
// Per-material indicator fields (seed paper Sec. 3.1, 3.3; DESIGN.md "Multi-material representation").
//
// For each material m: the signed distance to the boundary of its voxel mask (exact EDT; positive inside), smoothed
// by a Gaussian under the constraint that every voxel keeps its sign (Whitaker's constrained antialiasing): the
// smoothing removes the staircase but can never move an interface across a voxel centre, so argmax_m f_m at every
// voxel centre is that voxel's label, and layers one voxel thick or single-voxel components survive.
// Not done: the paper's "tightening" (a curvature flow limiting the curvature radius to r). Under the sign
// constraint it measured no effect here (the constraint already pins the smoothed surface at the staircase corners),
// so the sizing field measures curvature at the scale of a few voxels instead (sizing_field.cpp).
// Values are physical distances (local units), clamped to +-band outside a narrow band, and stored in sparse bricks.
#include <cstdint>
#include <string>
#include <vector>

#include "fields/brick_field.h"

namespace cpmesh::fields {

struct IndicatorOptions {
  double smoothing_sigma = 1.0;  // Gaussian sigma, in voxels of the smallest spacing
  int smoothing_iterations = 2;  // smooth + constrain rounds
  double band = 4.0;             // narrow-band half-width, in voxels of the smallest spacing
  double junction_fade = 3.0;    // voxels: smoothing fades out this close to where three or more labels meet (0: off)
};

struct IndicatorFields {
  Grid grid;
  double band = 0;                   // physical half-width of the stored band
  std::vector<uint16_t> labels;      // label value of each material, ascending
  std::vector<BrickField> fields;    // f_m, same order as labels
  std::vector<uint64_t> voxel_counts;

  size_t material_count() const { return labels.size(); }
  // Index (into labels) of argmax_m f_m at a continuous voxel-index position (trilinear samples).
  int material_at(const glm::dvec3& ijk) const;
  size_t memory_bytes() const;
};

// labels: grid.voxel_count() values, x fastest. Every label value present becomes a material (the background too).
IndicatorFields build_indicator_fields(const Grid& grid, const uint16_t* labels, const IndicatorOptions& options = {});

}  // namespace cpmesh::fields
