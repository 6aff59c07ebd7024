#pragma once
// Exact squared Euclidean distance transform on a voxel grid with anisotropic spacing (Felzenszwalb & Huttenlocher,
// "Distance transforms of sampled functions", 2012: a lower envelope of parabolas per line, one separable pass per
// axis). Lines run in parallel (TBB).
#include <cstdint>
#include <limits>
#include <span>

#include "fields/grid.h"

namespace cpmesh::fields {

// in/out: on input, 0 at seed voxels and +infinity (or any large value) elsewhere; on output, the squared physical
// distance from each voxel centre to the nearest seed centre. Sizes: grid.voxel_count().
// cap (physical, optional): a caller that reads nothing beyond this distance. Every voxel whose value would be
// under cap^2 (a hair over: rounding margin) still gets it exactly; the others get a value at least that, possibly
// +infinity. Each pass then drops the
// samples already farther than cap along its line (their parabolas cannot reach under cap^2), so lines away from
// every seed are skipped: the fields clamp their distances at a band of a few voxels.
void squared_distance_transform(const Grid& grid, std::span<float> values,
                                double cap = std::numeric_limits<double>::infinity());

// The 1-D pass on n samples spaced `spacing` apart, stride `stride` in `f` (exposed for tests); samples of cap2 or
// more contribute no parabola (the values there are then cap2 or more, or +infinity).
// v, z: scratch of n and n + 1 entries; d: scratch of n entries.
void squared_distance_1d(float* f, int n, size_t stride, double spacing, int* v, double* z, float* d,
                         double cap2 = std::numeric_limits<double>::infinity());

}  // namespace cpmesh::fields
