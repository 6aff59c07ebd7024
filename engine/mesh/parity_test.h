#pragma once
// Inside a closed triangle surface, by ray parity. Serves split_material (the tets in doubt after its flood) and
// interior_points (the octree's leaves).
#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::mesh {

// Inside a closed surface by the parity of its triangles crossed by a ray from p along +axis; p is nudged off the
// axis by a tiny odd offset so that the ray misses edges and vertices. A 2D grid over the triangles' projection.
class ParityTest {
 public:
  ParityTest(const std::vector<glm::dvec3>& P, const std::vector<std::array<uint32_t, 3>>& tri, int axis, double cell,
             const glm::dvec3& lo, const glm::dvec3& hi)
      : P_(P), tri_(tri), axis_(axis), a1_((axis + 1) % 3), a2_((axis + 2) % 3), cell_(cell), lo_(lo), hi_(hi) {
    nu_ = size_t((hi[a1_] - lo[a1_]) / cell) + 1;
    nv_ = size_t((hi[a2_] - lo[a2_]) / cell) + 1;
    cells_.resize(nu_ * nv_);
    for (uint32_t i = 0; i < tri.size(); ++i) {
      double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
      for (uint32_t v : tri[i]) {
        u0 = std::min(u0, P[v][a1_]), u1 = std::max(u1, P[v][a1_]);
        v0 = std::min(v0, P[v][a2_]), v1 = std::max(v1, P[v][a2_]);
      }
      for (size_t a = cu(u0); a <= cu(u1); ++a)
        for (size_t b = cv(v0); b <= cv(v1); ++b) cells_[b * nu_ + a].push_back(i);
    }
    nudge_ = 1e-9 * std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, 1.0});
  }
  bool inside(const glm::dvec3& q) const {
    const double u = q[a1_] + 0.7071067811865476 * nudge_, v = q[a2_] + 0.5772156649015329 * nudge_;
    if (u < lo_[a1_] || v < lo_[a2_] || u > hi_[a1_] || v > hi_[a2_]) return false;
    bool in = false;
    for (uint32_t i : cells_[cv(v) * nu_ + cu(u)]) {
      const glm::dvec3 &a = P_[tri_[i][0]], &b = P_[tri_[i][1]], &c = P_[tri_[i][2]];
      const double d = (b[a1_] - a[a1_]) * (c[a2_] - a[a2_]) - (c[a1_] - a[a1_]) * (b[a2_] - a[a2_]);
      if (d == 0) continue;
      const double s = ((u - a[a1_]) * (c[a2_] - a[a2_]) - (c[a1_] - a[a1_]) * (v - a[a2_])) / d;
      const double t = ((b[a1_] - a[a1_]) * (v - a[a2_]) - (u - a[a1_]) * (b[a2_] - a[a2_])) / d;
      if (s < 0 || t < 0 || s + t > 1) continue;
      in ^= a[axis_] + s * (b[axis_] - a[axis_]) + t * (c[axis_] - a[axis_]) > q[axis_];
    }
    return in;
  }

 private:
  size_t cu(double u) const { return std::min(nu_ - 1, size_t(std::max(0.0, (u - lo_[a1_]) / cell_))); }
  size_t cv(double v) const { return std::min(nv_ - 1, size_t(std::max(0.0, (v - lo_[a2_]) / cell_))); }
  const std::vector<glm::dvec3>& P_;
  const std::vector<std::array<uint32_t, 3>>& tri_;
  int axis_, a1_, a2_;
  double cell_, nudge_ = 0;
  glm::dvec3 lo_, hi_;
  size_t nu_ = 1, nv_ = 1;
  std::vector<std::vector<uint32_t>> cells_;
};

}  // namespace cpmesh::mesh
