#include "fields/distance_transform.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

namespace cpmesh::fields {

void squared_distance_1d(float* f, int n, size_t stride, double spacing, int* v, double* z, float* d, double cap2) {
  // Lower envelope of parabolas y = f(q) + (spacing * (x - q))^2 over sample positions q with finite f.
  constexpr double inf = std::numeric_limits<double>::infinity();
  const double s2 = spacing * spacing;
  const double limit = std::min(1e30, cap2);  // samples at or above it: no seed (or none within the cap)
  int k = -1;
  for (int q = 0; q < n; ++q) {
    const double fq = f[size_t(q) * stride];
    if (!(fq < limit)) continue;  // contributes no parabola
    if (k < 0) {
      k = 0;
      v[0] = q;
      z[0] = -inf;
      z[1] = inf;
      continue;
    }
    double s;
    while (true) {  // z[0] = -inf, so this stops at k = 0 at the latest
      const int p = v[k];
      const double fp = f[size_t(p) * stride];
      s = ((fq + s2 * double(q) * q) - (fp + s2 * double(p) * p)) / (2.0 * s2 * (q - p));
      if (s > z[k]) break;
      --k;
    }
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = inf;
  }
  if (k < 0) return;  // no seed on the line: every value stays infinite
  int j = 0;
  for (int q = 0; q < n; ++q) {
    while (z[j + 1] < q) ++j;
    const double dq = spacing * double(q - v[j]);
    d[q] = float(dq * dq + f[size_t(v[j]) * stride]);
  }
  for (int q = 0; q < n; ++q) f[size_t(q) * stride] = d[q];
}

void squared_distance_transform(const Grid& grid, std::span<float> values, double cap) {
  // (A little over the cap: the passes' float sums of a voxel within it stay under this.)
  const double cap2 = std::isinf(cap) ? cap : (cap * 1.001 + 1e-6) * (cap * 1.001 + 1e-6);
  const glm::ivec3 n = grid.dims;
  const size_t sx = 1, sy = size_t(n.x), sz = size_t(n.x) * size_t(n.y);
  // One pass per axis; the lines of a pass are independent.
  auto pass = [&](int axis) {
    const int len = n[axis];
    const int a = axis == 0 ? 1 : 0, b = axis == 2 ? 1 : 2;  // the two other axes
    const size_t stride = axis == 0 ? sx : (axis == 1 ? sy : sz);
    const size_t stride_a = a == 0 ? sx : sy, stride_b = b == 1 ? sy : sz;
    tbb::parallel_for(tbb::blocked_range2d<int>(0, n[b], 0, n[a]), [&](const tbb::blocked_range2d<int>& r) {
      std::vector<int> v(static_cast<size_t>(len));
      std::vector<double> z(static_cast<size_t>(len) + 1);
      std::vector<float> d(static_cast<size_t>(len));
      for (int jb = r.rows().begin(); jb < r.rows().end(); ++jb)
        for (int ja = r.cols().begin(); ja < r.cols().end(); ++ja)
          squared_distance_1d(values.data() + size_t(jb) * stride_b + size_t(ja) * stride_a, len, stride,
                              grid.spacing[axis], v.data(), z.data(), d.data(), cap2);
    });
  };
  pass(0);
  pass(1);
  pass(2);
}

}  // namespace cpmesh::fields
