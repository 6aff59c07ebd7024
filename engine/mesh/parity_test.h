#pragma once
// Inside a closed triangle surface, by ray parity. Serves split_material (the tets in doubt after its flood) and
// interior_points (the octree's leaves).
#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "mesh/grouped.h"

namespace cpmesh::mesh {

// Inside a closed surface by the parity of its triangles crossed by a ray from p along +axis; p is nudged off the
// axis by a tiny odd offset so that the ray misses edges and vertices.
// The triangles' projections are listed in 2D grids: level 0 of about `cell` (coarser where it would have over
// kMaxCells cells), each level above 4 times coarser, up to one cell. A triangle goes to the finest level where its
// box spans at most 4 x 4 cells, into each of those; a query looks in one cell per level, so it meets every triangle
// whose box holds it exactly once, and a few large triangles among small ones (a surface whose edges differ a lot)
// are neither listed in millions of cells nor make the cells too large for the rest.
class ParityTest {
 public:
  static constexpr double kMaxCells = 4.0 * 1024 * 1024;
  ParityTest(const std::vector<glm::dvec3>& P, const std::vector<std::array<uint32_t, 3>>& tri, int axis, double cell,
             const glm::dvec3& lo, const glm::dvec3& hi)
      : P_(P), tri_(tri), axis_(axis), a1_((axis + 1) % 3), a2_((axis + 2) % 3), lo_(lo), hi_(hi) {
    const double eu = hi[a1_] - lo[a1_], ev = hi[a2_] - lo[a2_];
    double c = cell;
    while ((eu / c + 1) * (ev / c + 1) > kMaxCells) c *= 1.25;
    size_t cells = 0;
    for (;; c *= 4) {
      const Level level{c, size_t(eu / c) + 1, size_t(ev / c) + 1, cells};
      levels_.push_back(level);
      cells += level.nu * level.nv;
      if (level.nu == 1 && level.nv == 1) break;
    }
    // A triangle's level and its box's cells there.
    auto place = [&](uint32_t i, int& l, size_t& a0, size_t& a1, size_t& b0, size_t& b1) {
      double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
      for (uint32_t v : tri[i]) {
        u0 = std::min(u0, P[v][a1_]), u1 = std::max(u1, P[v][a1_]);
        v0 = std::min(v0, P[v][a2_]), v1 = std::max(v1, P[v][a2_]);
      }
      for (l = 0;; ++l) {
        const Level& L = levels_[size_t(l)];
        a0 = cu(L, u0), a1 = cu(L, u1), b0 = cv(L, v0), b1 = cv(L, v1);
        if ((a1 - a0 < 4 && b1 - b0 < 4) || size_t(l) + 1 == levels_.size()) return;
      }
    };
    cells_ = group_by_key(cells, tri.size(), [&](size_t i, auto&& add) {
      int l;
      size_t a0, a1, b0, b1;
      place(uint32_t(i), l, a0, a1, b0, b1);
      const Level& L = levels_[size_t(l)];
      for (size_t b = b0; b <= b1; ++b)
        for (size_t a = a0; a <= a1; ++a) add(L.first + b * L.nu + a);
    });
    // Levels above the coarsest one holding a triangle need no look.
    size_t used = 1;
    for (size_t l = 0; l < levels_.size(); ++l)
      if (cells_.begin[levels_[l].first + levels_[l].nu * levels_[l].nv] > cells_.begin[levels_[l].first]) used = l + 1;
    levels_.resize(used);
    nudge_ = 1e-9 * std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, 1.0});
  }
  bool inside(const glm::dvec3& q) const {
    const double u = q[a1_] + 0.7071067811865476 * nudge_, v = q[a2_] + 0.5772156649015329 * nudge_;
    if (u < lo_[a1_] || v < lo_[a2_] || u > hi_[a1_] || v > hi_[a2_]) return false;
    bool in = false;
    for (const Level& L : levels_)
      for (uint32_t i : cells_[L.first + cv(L, v) * L.nu + cu(L, u)]) {
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
  struct Level {
    double cell;
    size_t nu, nv;  // cells along a1 and a2
    size_t first;   // its first cell's key
  };
  size_t cu(const Level& L, double u) const { return std::min(L.nu - 1, size_t(std::max(0.0, (u - lo_[a1_]) / L.cell))); }
  size_t cv(const Level& L, double v) const { return std::min(L.nv - 1, size_t(std::max(0.0, (v - lo_[a2_]) / L.cell))); }
  const std::vector<glm::dvec3>& P_;
  const std::vector<std::array<uint32_t, 3>>& tri_;
  int axis_, a1_, a2_;
  double nudge_ = 0;
  glm::dvec3 lo_, hi_;
  std::vector<Level> levels_;
  Grouped cells_;
};

}  // namespace cpmesh::mesh
