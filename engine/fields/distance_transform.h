#pragma once
// Exact squared Euclidean distance transform on a voxel grid with anisotropic spacing (Felzenszwalb & Huttenlocher,
// "Distance transforms of sampled functions", 2012: a lower envelope of parabolas per line, one separable pass per
// axis). Lines run in parallel (TBB).
#include <cstdint>
#include <span>

#include "fields/grid.h"

namespace cpmesh::fields {

// in/out: on input, 0 at seed voxels and +infinity (or any large value) elsewhere; on output, the squared physical
// distance from each voxel centre to the nearest seed centre. Sizes: grid.voxel_count().
void squared_distance_transform(const Grid& grid, std::span<float> values);

// The 1-D pass on n samples spaced `spacing` apart, stride `stride` in `f` (exposed for tests).
// v, z: scratch of n and n + 1 entries; d: scratch of n entries.
void squared_distance_1d(float* f, int n, size_t stride, double spacing, int* v, double* z, float* d);

}  // namespace cpmesh::fields
