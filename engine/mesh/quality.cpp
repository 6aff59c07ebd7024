#include "mesh/quality.h"

#include <algorithm>
#include <atomic>
#include <limits>
#include <cmath>
#include <functional>
#include <iterator>
#include <set>
#include <stdexcept>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include "io/synth_volumes.h"
#include "host/host_array.h"
#include "mesh/elements_around.h"
#include "mesh/face_key.h"
#include "mesh/grouped.h"

namespace cpmesh::mesh {

double radius_ratio(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const double la = glm::length(b - c), lb = glm::length(c - a), lc = glm::length(a - b);
  const double area = 0.5 * glm::length(glm::cross(b - a, c - a));
  if (area <= 0 || la * lb * lc <= 0) return 0;
  const double r_in = 2 * area / (la + lb + lc), r_circ = la * lb * lc / (4 * area);
  return 2 * r_in / r_circ;
}

namespace {

// The outward normals of the faces opposite corners 0..3, not normalized.
std::array<glm::dvec3, 4> outward_normals(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c,
                                          const glm::dvec3& d) {
  // Pointers, not copies: copying the corners into a local array stalled the loads that followed (store forwarding).
  const glm::dvec3* p[4] = {&a, &b, &c, &d};
  std::array<glm::dvec3, 4> n;
  for (int k = 0; k < 4; ++k) {
    const glm::dvec3 &pi = *p[(k + 1) % 4], &pj = *p[(k + 2) % 4], &pk = *p[k], &pl = *p[(k + 3) % 4];
    n[size_t(k)] = glm::cross(pj - pi, pl - pi);
    if (glm::dot(n[size_t(k)], pk - pi) > 0) n[size_t(k)] = -n[size_t(k)];
  }
  return n;
}

// Per edge (i, j), in the order (0,1) (0,2) (0,3) (1,2) (1,3) (2,3) of the other two corners k < l: the cosine of the
// angle between the outward normals n of the faces opposite k and l, clamped to [-1, 1]. The dihedral angle at the
// edge is pi - acos of it, which grows with it.
std::array<double, 6> normal_cosines(std::array<glm::dvec3, 4> n) {
  for (glm::dvec3& x : n) {
    const double len = glm::length(x);
    if (len > 0) x = x / len;
  }
  std::array<double, 6> out;
  int e = 0;
  for (size_t k = 0; k < 4; ++k)
    for (size_t l = k + 1; l < 4; ++l) out[size_t(e++)] = std::clamp(glm::dot(n[k], n[l]), -1.0, 1.0);
  return out;
}

std::array<double, 6> normal_cosines(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d) {
  return normal_cosines(outward_normals(a, b, c, d));
}

// The certain answers below leave this much room for the rounding of the exact computation (which is good to about
// 1e-15 in the normal range their tests require): where a test falls inside it, the exact value decides.
constexpr double kCertainMargin = 1e-9;

// The circumcentre of the tet a, a + u, a + v, a + w relative to a, given det = u . (v x w); meaningless where
// |det| < 1e-300 (radius_edge_ratio is infinite there).
glm::dvec3 circumcentre_from_a(const glm::dvec3& u, const glm::dvec3& v, const glm::dvec3& w, double det) {
  // Solve 2 (p - a) . x = |p|^2 - |a|^2 relative to a.
  return (glm::dot(u, u) * glm::cross(v, w) + glm::dot(v, v) * glm::cross(w, u) + glm::dot(w, w) * glm::cross(u, v)) /
         (2 * det);
}

}  // namespace

std::array<double, 6> dihedral_angles(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d) {
  // The dihedral angle at edge (i, j) is between the faces opposite the other two corners k, l: pi - angle(n_k, n_l).
  std::array<double, 6> out = normal_cosines(a, b, c, d);
  for (double& x : out) x = dihedral_from_cosine(x);
  return out;
}

std::array<double, 2> dihedral_range(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d) {
  const auto x = normal_cosines(a, b, c, d);
  const auto [lo, hi] = std::minmax_element(x.begin(), x.end());
  return {dihedral_from_cosine(*lo), dihedral_from_cosine(*hi)};
}

double min_dihedral_cosine(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d) {
  const auto x = normal_cosines(a, b, c, d);
  return *std::min_element(x.begin(), x.end());
}

double min_dihedral_cosine_unless_above(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c,
                                        const glm::dvec3& d, double bound) {
  const auto n = outward_normals(a, b, c, d);
  // Every cosine D / sqrt(S) (D = n_k . n_l, S = |n_k|^2 |n_l|^2) above t = bound + margin, tested squared: for
  // t < 0, D >= 0 or D^2 < t^2 S; for t >= 0, D > 0 and D^2 > t^2 S. Only where every |n_k|^2 lies well inside the
  // normal range (S and D^2 then neither overflow nor lose precision as subnormals; edges of about 1e-37 to 1e37):
  // a NaN fails that test.
  const double t = bound + kCertainMargin;
  const double s[4] = {glm::dot(n[0], n[0]), glm::dot(n[1], n[1]), glm::dot(n[2], n[2]), glm::dot(n[3], n[3])};
  auto in_range = [](double x) { return x >= 1e-150 && x <= 1e150; };
  if (t < 1 && in_range(s[0]) && in_range(s[1]) && in_range(s[2]) && in_range(s[3])) {
    bool above = true;
    for (size_t k = 0; k < 4 && above; ++k)
      for (size_t l = k + 1; l < 4 && above; ++l) {
        const double D = glm::dot(n[k], n[l]), T = t * t * (s[k] * s[l]);
        above = t < 0 ? (D >= 0 || D * D < T) : (D > 0 && D * D > T);
      }
    if (above) return HUGE_VAL;
  }
  const auto x = normal_cosines(n);
  return *std::min_element(x.begin(), x.end());
}

double min_dihedral(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d) {
  return dihedral_from_cosine(min_dihedral_cosine(a, b, c, d));
}

double radius_edge_ratio(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d) {
  const glm::dvec3 u = b - a, v = c - a, w = d - a;
  const double det = glm::dot(u, glm::cross(v, w));
  if (std::fabs(det) < 1e-300) return std::numeric_limits<double>::infinity();
  const glm::dvec3 x = circumcentre_from_a(u, v, w, det);
  const double shortest = std::min({glm::length(u), glm::length(v), glm::length(w), glm::length(c - b), glm::length(d - b), glm::length(d - c)});
  return glm::length(x) / shortest;
}

bool radius_edge_above(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d,
                       double limit) {
  const glm::dvec3 u = b - a, v = c - a, w = d - a;
  const double det = glm::dot(u, glm::cross(v, w));
  if (std::fabs(det) >= 1e-300 && limit >= 0) {
    // Squared: |x|^2 against limit^2 times the shortest edge's square, where both lie well inside the normal range
    // (a NaN fails that test).
    const glm::dvec3 x = circumcentre_from_a(u, v, w, det);
    const double r2 = glm::dot(x, x);
    const double bound = limit * limit * std::min({glm::dot(u, u), glm::dot(v, v), glm::dot(w, w), glm::dot(c - b, c - b),
                                                   glm::dot(d - b, d - b), glm::dot(d - c, d - c)});
    if (r2 >= 1e-290 && r2 <= 1e290 && bound >= 1e-290 && bound <= 1e290) {
      if (r2 < bound * (1 - kCertainMargin)) return false;
      if (r2 > bound * (1 + kCertainMargin)) return true;
    }
  }
  return radius_edge_ratio(a, b, c, d) > limit;
}

TriangleSums& TriangleSums::operator+=(const TriangleSums& o) {
  triangles += o.triangles;
  below_half += o.below_half;
  sum += o.sum;
  min = std::min(min, o.min);
  return *this;
}

TriangleStats TriangleSums::stats() const {
  TriangleStats s;
  s.triangles = triangles;
  if (triangles == 0) return s;
  s.mean_radius_ratio = sum / double(triangles);
  s.min_radius_ratio = min;
  s.share_below_half = double(below_half) / double(triangles);
  return s;
}

std::vector<TriangleSums> triangle_sums_by_group(const std::vector<glm::dvec3>& V,
                                                 const std::vector<std::array<uint32_t, 3>>& T,
                                                 const std::vector<uint32_t>& group, size_t groups) {
  if (!group.empty() && group.size() != T.size())
    throw std::invalid_argument("triangle_sums_by_group: one group per triangle");
  // Fixed chunks joined in order (as tet_stats_by_group), so that the sums are the same on any thread count.
  return tbb::parallel_deterministic_reduce(
      tbb::blocked_range<size_t>(0, T.size(), 16384), std::vector<TriangleSums>(groups),
      [&](const tbb::blocked_range<size_t>& r, std::vector<TriangleSums> acc) {
        for (size_t t = r.begin(); t != r.end(); ++t) {
          const double q = radius_ratio(V[T[t][0]], V[T[t][1]], V[T[t][2]]);
          TriangleSums& g = acc[group.empty() ? 0 : group[t]];
          ++g.triangles;
          g.sum += q;
          g.min = std::min(g.min, q);
          g.below_half += q < 0.5;
        }
        return acc;
      },
      [](std::vector<TriangleSums> a, const std::vector<TriangleSums>& b) {
        for (size_t g = 0; g < a.size(); ++g) a[g] += b[g];
        return a;
      });
}

TriangleStats triangle_stats(const std::vector<glm::dvec3>& V, const std::vector<std::array<uint32_t, 3>>& T) {
  return triangle_sums_by_group(V, T, {}, 1)[0].stats();
}

namespace {
// Every edge (a < b) with the number of triangles that use it, in ascending order of (a, b). A sorted array rather
// than a map: at the dense head's 3.3 M triangles the map's 10 M node insertions took most of the quality stage.
struct EdgeUse {
  uint32_t a, b;
  int uses;
};
uint64_t edge_key(uint32_t a, uint32_t b) { return uint64_t(std::min(a, b)) << 32 | std::max(a, b); }
std::vector<EdgeUse> edge_uses(const std::vector<std::array<uint32_t, 3>>& T) {
  std::vector<uint64_t> keys(T.size() * 3);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, T.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t < r.end(); ++t)
      for (int e = 0; e < 3; ++e) keys[t * 3 + size_t(e)] = edge_key(T[t][size_t(e)], T[t][size_t((e + 1) % 3)]);
  });
  tbb::parallel_sort(keys.begin(), keys.end());
  std::vector<EdgeUse> uses;
  for (size_t i = 0; i < keys.size();) {
    size_t j = i;
    while (j < keys.size() && keys[j] == keys[i]) ++j;
    uses.push_back({uint32_t(keys[i] >> 32), uint32_t(keys[i]), int(j - i)});
    i = j;
  }
  return uses;
}
}  // namespace

SurfaceCheck check_surface(const std::vector<std::array<uint32_t, 3>>& T, const std::vector<uint8_t>& on_curve) {
  SurfaceCheck c;
  for (const auto& e : edge_uses(T)) {
    if (e.uses > 2) ++c.nonmanifold_edges;
    if (e.uses == 1) {
      ++c.boundary_edges;
      if (!(on_curve[e.a] && on_curve[e.b])) ++c.open_edges;
    }
  }
  return c;
}

EdgeChecks check_edges(const std::vector<std::array<uint32_t, 3>>& T, const std::vector<uint32_t>& group,
                       const std::vector<std::array<uint16_t, 2>>& pair_of, size_t materials,
                       const std::vector<uint8_t>& on_curve) {
  if (group.size() != T.size()) throw std::invalid_argument("check_edges: one group per triangle");
  for (const auto& p : pair_of)
    if (p[0] >= materials || p[1] >= materials || p[0] == p[1])
      throw std::invalid_argument("check_edges: an interface's materials must be two distinct ones below " +
                                  std::to_string(materials));
  if (std::any_of(group.begin(), group.end(), [&](uint32_t g) { return g >= pair_of.size(); }))
    throw std::invalid_argument("check_edges: a triangle's group is not an interface");
  EdgeChecks out;
  out.interfaces.resize(pair_of.size());
  out.odd_edges.assign(materials, 0);
  // (edge, group) for every triangle edge, sorted: an edge's uses by each interface are then runs within its run.
  std::vector<std::pair<uint64_t, uint32_t>> entries(T.size() * 3);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, T.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t < r.end(); ++t)
      for (int e = 0; e < 3; ++e) entries[t * 3 + size_t(e)] = {edge_key(T[t][size_t(e)], T[t][size_t((e + 1) % 3)]), group[t]};
  });
  tbb::parallel_sort(entries.begin(), entries.end());
  std::vector<int> uses_of(materials, 0);
  std::vector<size_t> touched;
  for (size_t i = 0; i < entries.size();) {
    const uint64_t edge = entries[i].first;
    const uint32_t a = uint32_t(edge >> 32), b = uint32_t(edge);
    size_t j = i;
    for (; j < entries.size() && entries[j].first == edge;) {
      const uint32_t g = entries[j].second;
      size_t k = j;
      while (k < entries.size() && entries[k].first == edge && entries[k].second == g) ++k;
      const size_t uses = k - j;
      SurfaceCheck& c = out.interfaces[g];
      if (uses > 2) ++c.nonmanifold_edges;
      if (uses == 1) {
        ++c.boundary_edges;
        if (!(on_curve[a] && on_curve[b])) ++c.open_edges;
      }
      for (uint16_t m : pair_of[g]) {
        if (uses_of[m] == 0) touched.push_back(m);
        uses_of[m] += int(uses);
      }
      j = k;
    }
    for (size_t m : touched) {
      out.odd_edges[m] += size_t(uses_of[m] % 2);
      uses_of[m] = 0;
    }
    touched.clear();
    i = j;
  }
  return out;
}

std::vector<CurveEdge> triple_curve_edges(const std::vector<std::array<uint32_t, 3>>& T,
                                          const std::vector<std::array<uint16_t, 2>>& pair) {
  // (edge, pair) for every triangle edge, sorted: an edge's distinct pairs are then one run (no map of sets).
  std::vector<std::pair<uint64_t, uint32_t>> entries(T.size() * 3);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, T.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t < r.end(); ++t) {
      const uint32_t p = pair_key(pair[t][0], pair[t][1]);
      for (int e = 0; e < 3; ++e) entries[t * 3 + size_t(e)] = {edge_key(T[t][size_t(e)], T[t][size_t((e + 1) % 3)]), p};
    }
  });
  tbb::parallel_sort(entries.begin(), entries.end());
  std::vector<CurveEdge> out;
  for (size_t i = 0; i < entries.size();) {
    size_t j = i, pairs = 0;
    for (; j < entries.size() && entries[j].first == entries[i].first; ++j) pairs += j == i || entries[j].second != entries[j - 1].second;
    if (pairs >= 3) {  // rare: the edges along the curves
      std::set<uint16_t> set;
      for (size_t k = i; k < j; ++k) set.insert({uint16_t(entries[k].second >> 16), uint16_t(entries[k].second & 0xffff)});
      if (set.size() == 3) {
        CurveEdge c;
        c.a = uint32_t(entries[i].first >> 32);
        c.b = uint32_t(entries[i].first);
        std::copy(set.begin(), set.end(), c.materials.begin());
        out.push_back(c);
      }
    }
    i = j;
  }
  return out;
}

JunctionError junction_error(const io::Junctions& junctions, const std::vector<std::array<double, 3>>& vertices,
                             const std::vector<std::array<uint32_t, 3>>& triangles,
                             const std::vector<std::array<uint16_t, 2>>& pair, double unit,
                             const std::vector<uint8_t>* on_curve) {
  if (on_curve && on_curve->size() != vertices.size())
    throw std::invalid_argument("junction_error: on_curve has " + std::to_string(on_curve->size()) + " flags for " +
                                std::to_string(vertices.size()) + " vertices");
  JunctionError e;
  auto point = [&](const std::array<double, 3>& a, const std::array<double, 3>& b, double t) {
    return std::array<double, 3>{a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
  };
  for (const auto& c : triple_curve_edges(triangles, pair)) {
    if (on_curve && (!(*on_curve)[c.a] || !(*on_curve)[c.b])) continue;
    const auto& a = vertices[c.a];
    const auto& b = vertices[c.b];
    const double d = io::distance_to_triple_curve(junctions, c.materials, point(a, b, 0.5)) / unit;
    if (!(d < 1e300)) {  // three materials with no analytic curve between them
      ++e.spurious;
      continue;
    }
    e.mean += d;
    e.max = std::max(e.max, d);
    for (int q = 0; q <= 8; ++q)  // q = 4 is the midpoint
      e.max_whole_edge =
          std::max(e.max_whole_edge, io::distance_to_triple_curve(junctions, c.materials, point(a, b, q / 8.0)) / unit);
    ++e.edges;
  }
  if (e.edges) e.mean /= double(e.edges);
  return e;
}

namespace {

double orient(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d) {
  return glm::dot(b - a, glm::cross(c - a, d - a));
}

// The open segment pq crosses the open triangle abc (strictly: p and q on opposite sides of its plane, the line
// through the triangle's inside). sp, sq: orient(a, b, c, p) and orient(a, b, c, q).
bool segment_crosses(const glm::dvec3& p, const glm::dvec3& q, double sp, double sq, const glm::dvec3& a,
                     const glm::dvec3& b, const glm::dvec3& c) {
  if (!((sp > 0 && sq < 0) || (sp < 0 && sq > 0))) return false;
  const double u = orient(p, q, a, b), v = orient(p, q, b, c), w = orient(p, q, c, a);
  return (u > 0 && v > 0 && w > 0) || (u < 0 && v < 0 && w < 0);
}

bool triangles_cross(const std::vector<glm::dvec3>& V, const std::array<uint32_t, 3>& s,
                     const std::array<uint32_t, 3>& t) {
  int shared = 0, si = -1, ti = -1;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (s[size_t(i)] == t[size_t(j)]) {
        ++shared;
        si = i;
        ti = j;
      }
  if (shared >= 2) return false;
  // An edge of x crosses y: the sides of y's plane that x's vertices lie on, each computed once for the three edges
  // (most pairs the grid offers end here, every vertex on one side).
  auto edges_cross = [&](const std::array<uint32_t, 3>& x, const std::array<uint32_t, 3>& y, int skip_at) {
    const glm::dvec3 &a = V[y[0]], &b = V[y[1]], &c = V[y[2]];
    double side[3] = {0, 0, 0};
    for (int i = 0; i < 3; ++i)
      if (i != skip_at) side[i] = orient(a, b, c, V[x[size_t(i)]]);  // (the shared vertex's is not needed)
    for (int e = 0; e < 3; ++e) {
      // shared vertex at skip_at: only the edge opposite it, (skip_at + 1, skip_at + 2)
      if (skip_at >= 0 && e != (skip_at + 1) % 3) continue;
      const int f = (e + 1) % 3;
      if (segment_crosses(V[x[size_t(e)]], V[x[size_t(f)]], side[e], side[f], a, b, c)) return true;
    }
    return false;
  };
  return edges_cross(s, t, shared ? si : -1) || edges_cross(t, s, shared ? ti : -1);
}

}  // namespace

std::vector<std::array<uint32_t, 2>> crossing_triangles(const std::vector<glm::dvec3>& V,
                                                        const std::vector<std::array<uint32_t, 3>>& T,
                                                        const std::vector<uint8_t>* only) {
  std::vector<std::array<uint32_t, 2>> out;
  if (T.size() < 2) return out;
  const uint32_t nt = uint32_t(T.size());
  HostArray<double> lengths(nt);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, nt, 4096), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t t = r.begin(); t < r.end(); ++t) {
      const double l = glm::length(V[T[t][1]] - V[T[t][0]]);
      lengths[t] = l == l ? l : std::numeric_limits<double>::infinity();  // NaN would break nth_element's order
    }
  });
  std::nth_element(lengths.begin(), lengths.begin() + std::ptrdiff_t(nt / 2), lengths.end());
  double width = std::max(2 * lengths[nt / 2], 1e-9);
  if (!std::isfinite(width)) width = 1.0;  // a median edge through a non-finite vertex: the cell count sets it below
  auto box = [&](const std::array<uint32_t, 3>& t, glm::dvec3& lo, glm::dvec3& hi) {
    lo = glm::min(V[t[0]], glm::min(V[t[1]], V[t[2]]));
    hi = glm::max(V[t[0]], glm::max(V[t[1]], V[t[2]]));
  };
  // A dense grid over the triangles' bounding box, its cells' triangle lists by counting sort (every step parallel:
  // the smoothing calls this once per round on meshes of millions of triangles). At most 2 cells per triangle: a
  // wider cell where the surface is sparse in a large box.
  using Bounds = std::array<glm::dvec3, 2>;
  const Bounds bounds = tbb::parallel_reduce(
      tbb::blocked_range<uint32_t>(0, nt, 4096),
      Bounds{glm::dvec3(std::numeric_limits<double>::infinity()), glm::dvec3(-std::numeric_limits<double>::infinity())},
      [&](const tbb::blocked_range<uint32_t>& r, Bounds b) {
        for (uint32_t t = r.begin(); t < r.end(); ++t)
          for (uint32_t v : T[t])
            if (std::isfinite(V[v].x + V[v].y + V[v].z)) {  // (a non-finite vertex goes to a face cell: crosses nothing)
              b[0] = glm::min(b[0], V[v]);
              b[1] = glm::max(b[1], V[v]);
            }
        return b;
      },
      [](const Bounds& a, const Bounds& b) { return Bounds{glm::min(a[0], b[0]), glm::max(a[1], b[1])}; });
  const glm::dvec3 lo = bounds[0], hi = bounds[1];  // (not a structured binding: lambdas below capture them)
  if (!(lo.x <= hi.x)) return out;
  const glm::dvec3 extent = hi - lo;
  const double max_cells = 2.0 * double(nt) + 64.0;
  const double cells_wanted = (extent.x / width + 1) * (extent.y / width + 1) * (extent.z / width + 1);
  if (cells_wanted > max_cells) width *= std::cbrt(cells_wanted / max_cells) * 1.01;
  const glm::ivec3 dims = glm::ivec3(glm::floor(extent / width)) + 1;
  const size_t cells = size_t(dims.x) * size_t(dims.y) * size_t(dims.z);
  auto cell_of = [&](const glm::dvec3& p) {
    const glm::dvec3 c = glm::clamp(glm::floor((p - lo) / width), glm::dvec3(0.0), glm::dvec3(dims - 1));
    return glm::ivec3(c.x == c.x ? c.x : 0.0, c.y == c.y ? c.y : 0.0, c.z == c.z ? c.z : 0.0);
  };
  auto cell_index = [&](const glm::ivec3& c) {
    return (size_t(c.z) * size_t(dims.y) + size_t(c.y)) * size_t(dims.x) + size_t(c.x);
  };
  auto for_cells = [&](const glm::dvec3& a, const glm::dvec3& b, auto&& visit) {
    const glm::ivec3 ca = cell_of(a), cb = cell_of(b);
    for (int z = ca.z; z <= cb.z; ++z)
      for (int y = ca.y; y <= cb.y; ++y)
        for (int x = ca.x; x <= cb.x; ++x) visit(cell_index({x, y, z}));
  };
  // Every triangle's box, once, exact (double) and rounded outward to float: the float boxes put the triangles in
  // cells and filter the pairs cheaply; a pair they let through must also pass the exact boxes' test, so the pairs
  // tested are those whose exact boxes meet (triangles_cross is plain floating point, and near-touching triangles
  // whose exact boxes do not meet could otherwise be reported).
  using Box = std::array<glm::vec3, 2>;
  HostArray<Box> boxes(nt);
  HostArray<std::array<glm::dvec3, 2>> exact(nt);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, nt, 4096), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t t = r.begin(); t < r.end(); ++t) {
      glm::dvec3 a, b;
      box(T[t], a, b);
      exact[t] = {a, b};
      for (int k = 0; k < 3; ++k) {
        float down = float(a[k]), up = float(b[k]);
        if (double(down) > a[k]) down = std::nextafter(down, -std::numeric_limits<float>::infinity());
        if (double(up) < b[k]) up = std::nextafter(up, std::numeric_limits<float>::infinity());
        boxes[t][0][k] = down;
        boxes[t][1][k] = up;
      }
    }
  });
  const Grouped in_cell = group_by_key(
      cells, nt, [&](size_t t, auto&& add) { for_cells(glm::dvec3(boxes[t][0]), glm::dvec3(boxes[t][1]), add); });
  // The boxes again in the cells' order, so that a cell's pairs read consecutive memory: read through the
  // triangles' own order, the candidates' boxes were scattered over the whole array (most of this function's time
  // went to those cache misses on meshes of millions of triangles).
  HostArray<Box> cell_boxes(in_cell.list.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, in_cell.list.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t k = r.begin(); k < r.end(); ++k) cell_boxes[k] = boxes[in_cell.list[k]];
  });
  // Every pair of triangles in one cell whose boxes meet, where at least one is flagged (`only`). Two boxes that
  // meet share the cell of their overlap's lowest corner (each lies in it): the pair is tested there only.
  tbb::enumerable_thread_specific<std::vector<std::array<uint32_t, 2>>> found;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, cells, 64), [&](const tbb::blocked_range<size_t>& r) {
    auto& mine = found.local();
    for (size_t c = r.begin(); c < r.end(); ++c) {
      const size_t first = in_cell.begin[c], last = in_cell.begin[c + 1];
      for (size_t i = first; i + 1 < last; ++i) {
        const uint32_t t = in_cell.list[i];
        const bool t_flagged = !only || (*only)[t];
        const glm::vec3 &a = cell_boxes[i][0], &b = cell_boxes[i][1];
        for (size_t j = i + 1; j < last; ++j) {
          const uint32_t u = in_cell.list[j];
          if (!t_flagged && !(*only)[u]) continue;
          const glm::vec3 &ulo = cell_boxes[j][0], &uhi = cell_boxes[j][1];
          if (glm::any(glm::lessThan(uhi, a)) || glm::any(glm::greaterThan(ulo, b))) continue;
          if (cell_index(cell_of(glm::dvec3(glm::max(a, ulo)))) != c) continue;
          const auto &et = exact[t], &eu = exact[u];
          if (glm::any(glm::lessThan(eu[1], et[0])) || glm::any(glm::greaterThan(eu[0], et[1]))) continue;
          if (triangles_cross(V, T[t], T[u])) mine.push_back({std::min(t, u), std::max(t, u)});
        }
      }
    }
  });
  for (const auto& f : found) out.insert(out.end(), f.begin(), f.end());
  std::sort(out.begin(), out.end());
  return out;
}

FaceConformity nonconforming_faces(const std::vector<glm::dvec3>& P, const std::vector<std::array<uint32_t, 4>>& tets,
                                   const std::vector<uint16_t>& material,
                                   const std::vector<std::array<uint32_t, 3>>& triangles,
                                   const std::vector<std::array<uint16_t, 2>>& pair) {
  struct Side {
    FaceKey key;
    uint16_t a, b;  // materials, a <= b
    bool operator<(const Side& o) const { return key != o.key ? key < o.key : a != o.a ? a < o.a : b < o.b; }
    bool operator==(const Side& o) const { return key == o.key && a == o.a && b == o.b; }
  };
  std::vector<Side> faces(4 * tets.size(), {FaceKey({0, 0, 0}), 0, 0});
  tbb::parallel_for(tbb::blocked_range<size_t>(0, tets.size()), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t < r.end(); ++t)
      for (int i = 0; i < 4; ++i) faces[4 * t + size_t(i)] = {FaceKey(face_opposite(tets[t], i)), material[t], material[t]};
  });
  tbb::parallel_sort(faces.begin(), faces.end());
  std::vector<Side> between;  // each face between two materials once, as (key, the pair)
  for (size_t i = 0; i < faces.size();) {
    size_t j = i;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    const uint16_t m1 = faces[i].a, m2 = j - i > 1 ? faces[i + 1].a : uint16_t(0);
    if (m1 != m2 || j - i > 2) between.push_back({faces[i].key, std::min(m1, m2), std::max(m1, m2)});
    i = j;
  }
  std::vector<Side> given;
  given.reserve(triangles.size());
  for (size_t t = 0; t < triangles.size(); ++t) given.push_back({FaceKey(triangles[t]), pair[t][0], pair[t][1]});
  std::sort(given.begin(), given.end());
  std::vector<Side> odd;
  std::set_symmetric_difference(between.begin(), between.end(), given.begin(), given.end(), std::back_inserter(odd));
  FaceConformity out;
  out.mismatches = odd.size();
  if (!odd.empty()) out.first = (P[odd[0].key.v[0]] + P[odd[0].key.v[1]] + P[odd[0].key.v[2]]) / 3.0;
  return out;
}

size_t odd_edges(const std::vector<std::array<uint32_t, 3>>& T) {
  size_t odd = 0;
  for (const auto& e : edge_uses(T)) odd += size_t(e.uses % 2);
  return odd;
}

std::vector<TetStats> tet_stats_by_group(const std::vector<glm::dvec3>& V, const std::vector<std::array<uint32_t, 4>>& tets,
                                         const std::vector<uint16_t>& group, size_t groups) {
  if (group.size() != tets.size()) throw std::invalid_argument("tet_stats_by_group: one group per tet");
  // Fixed chunks joined in order, so that the mean is the same sum on any thread count.
  struct Sums {
    std::vector<TetStats> s;
  };
  auto empty = [&] {
    Sums z;
    z.s.resize(groups);
    for (TetStats& x : z.s) x.min_dihedral_deg = 180;
    return z;
  };
  auto join = [](Sums a, const Sums& b) {
    for (size_t g = 0; g < a.s.size(); ++g) {
      TetStats &x = a.s[g];
      const TetStats& y = b.s[g];
      x.tets += y.tets;
      // b's tets come after a's: a keeps a tie.
      if (y.worst_tet != SIZE_MAX && (x.worst_tet == SIZE_MAX || y.min_dihedral_deg < x.min_dihedral_deg)) {
        x.worst_tet = y.worst_tet;
        x.min_dihedral_deg = y.min_dihedral_deg;
      }
      x.max_dihedral_deg = std::max(x.max_dihedral_deg, y.max_dihedral_deg);
      x.max_radius_edge = std::max(x.max_radius_edge, y.max_radius_edge);
      x.mean_radius_edge += y.mean_radius_edge;  // the sum until the end
    }
    return a;
  };
  Sums all = tbb::parallel_deterministic_reduce(
      tbb::blocked_range<size_t>(0, tets.size(), 16384), empty(),
      [&](const tbb::blocked_range<size_t>& r, Sums acc) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
          if (group[i] >= groups) throw std::invalid_argument("tet_stats_by_group: group out of range");
          const auto& t = tets[i];
          TetStats& x = acc.s[group[i]];
          const auto range = dihedral_range(V[t[0]], V[t[1]], V[t[2]], V[t[3]]);
          if (const double d = range[0] * 180 / M_PI; d < x.min_dihedral_deg || x.worst_tet == SIZE_MAX) {
            x.min_dihedral_deg = std::min(x.min_dihedral_deg, d);
            x.worst_tet = i;
          }
          x.max_dihedral_deg = std::max(x.max_dihedral_deg, range[1] * 180 / M_PI);
          const double re = radius_edge_ratio(V[t[0]], V[t[1]], V[t[2]], V[t[3]]);
          x.max_radius_edge = std::max(x.max_radius_edge, re);
          x.mean_radius_edge += re;
          ++x.tets;
        }
        return acc;
      },
      join);
  for (TetStats& x : all.s) {
    if (x.tets == 0) {
      x = TetStats{};
      continue;
    }
    x.mean_radius_edge /= double(x.tets);
    const auto& t = tets[x.worst_tet];
    x.worst_centroid = (V[t[0]] + V[t[1]] + V[t[2]] + V[t[3]]) / 4.0;
  }
  return all.s;
}

size_t count_below_dihedral(const std::vector<glm::dvec3>& P, const std::vector<std::array<uint32_t, 4>>& tets,
                            double min_deg) {
  const double bound = min_deg * M_PI / 180;
  return tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, tets.size()), size_t(0),
      [&](const tbb::blocked_range<size_t>& r, size_t n) {
        for (size_t t = r.begin(); t != r.end(); ++t) n += min_dihedral(P, tets[t]) < bound;
        return n;
      },
      std::plus<>());
}

TetStats tet_stats(const std::vector<glm::dvec3>& V, const std::vector<std::array<uint32_t, 4>>& tets) {
  return tet_stats_by_group(V, tets, std::vector<uint16_t>(tets.size(), 0), 1)[0];
}

TetStats combined(const std::vector<TetStats>& parts) {
  TetStats s;
  double sum = 0;
  for (const TetStats& x : parts) {
    if (x.tets == 0) continue;
    if (s.tets == 0 || x.min_dihedral_deg < s.min_dihedral_deg ||
        (x.min_dihedral_deg == s.min_dihedral_deg && x.worst_tet < s.worst_tet)) {  // a tie: the first tet
      s.min_dihedral_deg = x.min_dihedral_deg;
      s.worst_tet = x.worst_tet;
      s.worst_centroid = x.worst_centroid;
    }
    s.max_dihedral_deg = std::max(s.max_dihedral_deg, x.max_dihedral_deg);
    s.max_radius_edge = std::max(s.max_radius_edge, x.max_radius_edge);
    sum += x.mean_radius_edge * double(x.tets);
    s.tets += x.tets;
  }
  if (s.tets > 0) s.mean_radius_edge = sum / double(s.tets);
  return s;
}

}  // namespace cpmesh::mesh
