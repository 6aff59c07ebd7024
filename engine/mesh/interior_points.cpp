#include "mesh/interior_points.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <tbb/parallel_for.h>

#include "mesh/grouped.h"
#include "mesh/local_surface.h"
#include "mesh/parity_test.h"

namespace cpmesh::mesh {

namespace {

// The surface's vertices in cubes of one edge (compressed rows), and over them a pyramid of blocks of 2^l cubes
// (l = 1, 2, ... up to one block) with the smallest h of each block's vertices: a query skips a block where no
// vertex in it can lower s or d, which bounds its work where the surface's edge lengths differ a lot.
class VertexGrid {
 public:
  VertexGrid(const std::vector<glm::dvec3>& P, const std::vector<double>& h, double cell, const glm::dvec3& lo,
             const glm::dvec3& hi)
      : P_(P), h_(h), lo_(lo) {
    // At most about 16 M cubes: a surface with a few large triangles far apart gets larger ones.
    constexpr double kMaxCubes = 16.0 * 1024 * 1024;
    const glm::dvec3 extent = hi - lo;
    auto cubes = [&](double c) { return (extent.x / c + 1) * (extent.y / c + 1) * (extent.z / c + 1); };
    cell_ = cell;
    while (cubes(cell_) > kMaxCubes) cell_ *= 1.25;
    n_ = glm::ivec3(glm::floor(extent / cell_)) + 1;
    h_min_ = *std::min_element(h.begin(), h.end());
    cubes_ = group_by_key(size_t(n_.x) * size_t(n_.y) * size_t(n_.z), P.size(),
                          [&](size_t v, auto&& add) { add(index(n_, cube_of(P[v]))); });
    constexpr double inf = std::numeric_limits<double>::infinity();
    glm::ivec3 dims = n_;
    while (dims != glm::ivec3(1)) {
      const glm::ivec3 below = dims;
      dims = (dims + 1) / 2;
      Level level{dims, std::vector<double>(size_t(dims.x) * size_t(dims.y) * size_t(dims.z), inf)};
      if (levels_.empty()) {
        for (size_t v = 0; v < P.size(); ++v) {
          double& m = level.least_h[index(dims, cube_of(P[v]) / 2)];
          m = std::min(m, h[v]);
        }
      } else {
        const Level& fine = levels_.back();
        for (int k = 0; k < below.z; ++k)
          for (int j = 0; j < below.y; ++j)
            for (int i = 0; i < below.x; ++i) {
              double& m = level.least_h[index(dims, glm::ivec3(i, j, k) / 2)];
              m = std::min(m, fine.least_h[index(below, {i, j, k})]);
            }
      }
      levels_.push_back(std::move(level));
    }
  }

  // s = min over the vertices v of (h_v + grading |x - v|) and d = min |x - v|: first the cubes around x's (x clamped
  // into the grid) ring by ring, up to kRings, until no farther vertex can lower either by the smallest h of all;
  // then, where that bound is too weak (near coarse parts of a surface whose edges differ a lot), down the pyramid
  // from its top block, nearer blocks first, past the blocks and cubes where no vertex can lower either by their own
  // smallest h. Exact: the same s and d as over all vertices. Rings alone scanned about ((s - h_min) / grading /
  // cube)^3 cubes a query: a sphere of edges about 10 beside one of 0.033 took 2.0 s, 0.11 s now (with the parity
  // test's levels); the head's materials the same points, 0.39 s against 0.51 for material 4 (2 cores).
  void query(const glm::dvec3& x, double grading, double& s, double& d) const {
    s = d = std::numeric_limits<double>::infinity();
    const glm::ivec3 c = cube_of(x);
    auto scan = [&](const glm::ivec3& cube) {
      for (uint32_t v : cubes_[index(n_, cube)]) {
        const double l = glm::length(P_[v] - x);
        d = std::min(d, l);
        s = std::min(s, h_[v] + grading * l);
      }
    };
    constexpr int kRings = 2;
    for (int r = 0; r <= kRings + 1; ++r) {
      // Every vertex in ring r (cubes at Chebyshev distance r) lies at least (r - 1) cubes from x.
      const double nearest = (r - 1) * cell_;
      if (nearest >= d && h_min_ + grading * nearest >= s) return;
      if (r > 0 && c.x - r < 0 && c.y - r < 0 && c.z - r < 0 && c.x + r >= n_.x && c.y + r >= n_.y && c.z + r >= n_.z)
        return;  // the ring lies wholly outside the grid
      if (r > kRings) break;
      const glm::ivec3 lo = glm::max(c - r, glm::ivec3(0)), hi = glm::min(c + r, n_ - 1);
      for (int k = lo.z; k <= hi.z; ++k)
        for (int j = lo.y; j <= hi.y; ++j) {
          if (std::abs(k - c.z) == r || std::abs(j - c.y) == r) {
            for (int i = lo.x; i <= hi.x; ++i) scan({i, j, k});
          } else {  // the row crosses the ring's inside: its two ends only
            if (c.x - r >= 0) scan({c.x - r, j, k});
            if (r > 0 && c.x + r < n_.x) scan({c.x + r, j, k});
          }
        }
    }
    // Whether a box of `size` cubes at `corner` (in cubes) whose vertices have h of at least least_h may hold a
    // vertex that lowers s or d; the distances shrunk by a relative 1e-9 against rounding.
    auto may_lower = [&](const glm::ivec3& corner, int size, double least_h) {
      if (least_h == std::numeric_limits<double>::infinity()) return false;  // no vertex
      const glm::dvec3 box_lo = lo_ + glm::dvec3(corner) * cell_, box_hi = box_lo + double(size) * cell_;
      const double dist = (1.0 - 1e-9) * glm::length(glm::max(glm::max(box_lo - x, x - box_hi), glm::dvec3(0.0)));
      return dist < d || least_h + grading * dist < s;
    };
    auto descend = [&](auto&& self, int l, const glm::ivec3& node) -> void {
      const Level& level = levels_[size_t(l) - 1];
      const double least_h = level.least_h[index(level.dims, node)];
      if (!may_lower(node * (1 << l), 1 << l, least_h)) return;
      const glm::ivec3 below = l == 1 ? n_ : levels_[size_t(l) - 2].dims;
      // The children in the pyramid's level below (cubes at l = 1), the one nearest x's first.
      glm::ivec3 kids[8];
      double far[8];
      int count = 0;
      for (int o = 0; o < 8; ++o) {
        const glm::ivec3 kid = 2 * node + glm::ivec3(o & 1, (o >> 1) & 1, o >> 2);
        if (glm::any(glm::greaterThanEqual(kid, below))) continue;
        const double f = glm::length(lo_ + (glm::dvec3(kid) + 0.5) * double(1 << (l - 1)) * cell_ - x);
        int i = count++;  // insertion by the distance of its middle
        for (; i > 0 && far[i - 1] > f; --i) far[i] = far[i - 1], kids[i] = kids[i - 1];
        far[i] = f, kids[i] = kid;
      }
      for (int i = 0; i < count; ++i) {
        const glm::ivec3& kid = kids[i];
        if (l > 1) {
          self(self, l - 1, kid);
        } else if (glm::any(glm::greaterThan(glm::abs(kid - c), glm::ivec3(kRings))) && may_lower(kid, 1, least_h)) {
          scan(kid);  // (the rings are done)
        }
      }
    };
    if (!levels_.empty()) descend(descend, int(levels_.size()), glm::ivec3(0));
  }

 private:
  struct Level {
    glm::ivec3 dims;
    std::vector<double> least_h;  // per block: the smallest h of its vertices (infinity: none)
  };
  glm::ivec3 cube_of(const glm::dvec3& x) const {
    return glm::clamp(glm::ivec3(glm::floor((x - lo_) / cell_)), glm::ivec3(0), n_ - 1);
  }
  static size_t index(const glm::ivec3& dims, const glm::ivec3& c) {
    return (size_t(c.z) * size_t(dims.y) + size_t(c.y)) * size_t(dims.x) + size_t(c.x);
  }
  const std::vector<glm::dvec3>& P_;
  const std::vector<double>& h_;
  glm::dvec3 lo_;
  double cell_ = 1, h_min_ = 0;
  glm::ivec3 n_{1};
  Grouped cubes_;
  std::vector<Level> levels_;  // levels_[l - 1]: blocks of 2^l cubes a side
};

}  // namespace

std::vector<glm::dvec3> interior_points(const std::vector<glm::dvec3>& points,
                                        const std::vector<std::array<uint32_t, 3>>& triangles,
                                        const InteriorPointOptions& options) {
  // (A clearance of 0 would let a point fall on a surface vertex, which TetGen may then drop instead of it.)
  if (!(options.grading > 0 && options.cell > 0 && options.grading * options.cell >= 1 && options.clearance > 0))
    throw std::invalid_argument("interior_points: grading, cell and clearance must be positive, grading x cell >= 1");
  if (triangles.empty()) return {};
  // The surface's vertices, numbered locally, and their mean edge lengths.
  const LocalSurface surface = local_surface(points, triangles);
  const std::vector<glm::dvec3>& P = surface.points;
  const std::vector<std::array<uint32_t, 3>>& tri = surface.triangles;
  std::vector<double> h(P.size(), 0.0);
  std::vector<uint32_t> edges(P.size(), 0);
  double edge_sum = 0;
  for (const auto& t : tri)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = t[size_t(k)], b = t[size_t((k + 1) % 3)];
      const double l = glm::length(P[a] - P[b]);
      h[a] += l, h[b] += l, ++edges[a], ++edges[b];
      edge_sum += l;
    }
  for (size_t v = 0; v < P.size(); ++v) h[v] /= double(edges[v]);
  const double mean_edge = edge_sum / double(3 * tri.size());
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (const auto& p : P) lo = glm::min(lo, p), hi = glm::max(hi, p);
  // A vertex whose edges all have no length (a collapsed component) would split cubes down to rounding.
  if (!(mean_edge > 0) || !std::isfinite(mean_edge) || !(*std::min_element(h.begin(), h.end()) > 0)) return {};

  const VertexGrid grid(P, h, 2 * mean_edge, lo, hi);
  const ParityTest parity(P, tri, 0, 2 * mean_edge, lo, hi);
  const double g = options.grading;
  // A cube (centre c, edge L): outside where no surface vertex lies within its corners' reach and its centre is
  // outside; split while L > cell x s(c) (grading x cell >= 1: then a vertex lies within L of c, so the recursion
  // ends near the surface at cubes of about cell x h); else a leaf, its centre kept where clear and inside.
  enum class Cube { outside, split, leaf };
  auto classify = [&](const glm::dvec3& c, double L, bool& keep) {
    double s, d;
    grid.query(c, g, s, d);
    keep = false;
    if (d > 0.8660254037844387 * L && !parity.inside(c)) return Cube::outside;
    if (L > options.cell * s) return Cube::split;
    keep = d >= options.clearance * s && parity.inside(c);
    return Cube::leaf;
  };
  auto child = [](const glm::dvec3& c, double L, int o) {
    return c + 0.25 * L * glm::dvec3(o & 1 ? 1 : -1, o & 2 ? 1 : -1, o & 4 ? 1 : -1);
  };
  struct Task {
    glm::dvec3 centre;
    double edge;
  };
  // The octree's top levels in depth-first order, serially; below them each subtree on its own (in parallel), and
  // the leaves concatenated in the tasks' order: the depth-first order of the whole octree.
  constexpr int kTopLevels = 3;
  std::vector<Task> tasks;
  auto top = [&](auto&& self, const glm::dvec3& c, double L, int depth) -> void {
    if (depth == kTopLevels) return tasks.push_back({c, L});
    bool keep;
    const Cube kind = classify(c, L, keep);
    if (kind == Cube::outside) return;
    if (kind == Cube::leaf) return tasks.push_back({c, L});  // (classified again there: the same answer)
    for (int o = 0; o < 8; ++o) self(self, child(c, L, o), L / 2, depth + 1);
  };
  const glm::dvec3 extent = hi - lo;
  top(top, 0.5 * (lo + hi), 1.0001 * std::max({extent.x, extent.y, extent.z, mean_edge}), 0);
  std::vector<std::vector<glm::dvec3>> found(tasks.size());
  tbb::parallel_for(size_t(0), tasks.size(), [&](size_t i) {
    auto visit = [&](auto&& self, const glm::dvec3& c, double L) -> void {
      bool keep;
      const Cube kind = classify(c, L, keep);
      if (kind == Cube::split)
        for (int o = 0; o < 8; ++o) self(self, child(c, L, o), L / 2);
      else if (keep)
        found[i].push_back(c);
    };
    visit(visit, tasks[i].centre, tasks[i].edge);
  });
  std::vector<glm::dvec3> out;
  for (const auto& f : found) out.insert(out.end(), f.begin(), f.end());
  return out;
}

}  // namespace cpmesh::mesh
