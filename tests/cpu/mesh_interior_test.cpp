// Interior points for TetGen (interior_points.h): inside the surfaces, clear of them by the sizing, graded, the same
// on any thread count, and what TetGen makes of them.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <stdexcept>

#include <tbb/global_control.h>

#include "icosphere.h"
#include "mesh/interior_points.h"
#include "mesh/local_surface.h"
#include "mesh/parity_test.h"
#include "mesh/quality.h"
#include "mesh/tetgen.h"
#include "mesh/volume_mesh.h"

using namespace cpmesh;
using test::enclosed_volume;
using test::icosphere;
using test::Sphere;

namespace {

// The sizing of interior_points.h by brute force: min over the triangles' vertices of (h_v + grading |x - v|), and
// the distance to the nearest vertex.
struct Sizing {
  std::vector<glm::dvec3> vertices;
  std::vector<double> h;
  Sizing(const std::vector<glm::dvec3>& P, const std::vector<std::array<uint32_t, 3>>& T) {
    std::vector<double> sum(P.size(), 0.0);
    std::vector<int> count(P.size(), 0);
    for (const auto& t : T)
      for (int k = 0; k < 3; ++k) {
        const double l = glm::length(P[t[size_t(k)]] - P[t[size_t((k + 1) % 3)]]);
        sum[t[size_t(k)]] += l, sum[t[size_t((k + 1) % 3)]] += l;
        ++count[t[size_t(k)]], ++count[t[size_t((k + 1) % 3)]];
      }
    for (size_t v = 0; v < P.size(); ++v)
      if (count[v] > 0) vertices.push_back(P[v]), h.push_back(sum[v] / count[v]);
  }
  void at(const glm::dvec3& x, double grading, double& s, double& d) const {
    s = d = std::numeric_limits<double>::infinity();
    for (size_t v = 0; v < vertices.size(); ++v) {
      const double l = glm::length(vertices[v] - x);
      s = std::min(s, h[v] + grading * l), d = std::min(d, l);
    }
  }
};

double nearest_other(const std::vector<glm::dvec3>& P, size_t i) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t j = 0; j < P.size(); ++j)
    if (j != i) best = std::min(best, glm::length(P[j] - P[i]));
  return best;
}

// interior_points.h written out plainly: one depth-first recursion, the sizing by brute force, the same parity test.
std::vector<glm::dvec3> reference_points(const std::vector<glm::dvec3>& points,
                                         const std::vector<std::array<uint32_t, 3>>& triangles,
                                         const mesh::InteriorPointOptions& options) {
  const mesh::LocalSurface surface = mesh::local_surface(points, triangles);
  const Sizing sizing(surface.points, surface.triangles);
  double edge_sum = 0;
  for (const auto& t : surface.triangles)
    for (int k = 0; k < 3; ++k) edge_sum += glm::length(surface.points[t[size_t(k)]] - surface.points[t[size_t((k + 1) % 3)]]);
  const double mean_edge = edge_sum / double(3 * surface.triangles.size());
  glm::dvec3 lo(1e300), hi(-1e300);
  for (const auto& p : surface.points) lo = glm::min(lo, p), hi = glm::max(hi, p);
  const mesh::ParityTest parity(surface.points, surface.triangles, 0, 2 * mean_edge, lo, hi);
  std::vector<glm::dvec3> out;
  auto visit = [&](auto&& self, const glm::dvec3& c, double L) -> void {
    double s, d;
    sizing.at(c, options.grading, s, d);
    if (d > 0.8660254037844387 * L && !parity.inside(c)) return;
    if (L > options.cell * s) {
      for (int o = 0; o < 8; ++o) self(self, c + 0.25 * L * glm::dvec3(o & 1 ? 1 : -1, o & 2 ? 1 : -1, o & 4 ? 1 : -1), L / 2);
      return;
    }
    if (d >= options.clearance * s && parity.inside(c)) out.push_back(c);
  };
  const glm::dvec3 extent = hi - lo;
  visit(visit, 0.5 * (lo + hi), 1.0001 * std::max({extent.x, extent.y, extent.z, mean_edge}));
  return out;
}

// Two surfaces as one list of points and triangles.
Sphere joined(const Sphere& a, const Sphere& b) {
  Sphere s = a;
  s.points.insert(s.points.end(), b.points.begin(), b.points.end());
  for (auto t : b.triangles) {
    for (auto& v : t) v += uint32_t(a.points.size());
    s.triangles.push_back(t);
  }
  return s;
}

}  // namespace

TEST_CASE("interior_points: the plain recursion's points, in its order, on uneven surfaces and boxes") {
  // A jittered ellipsoid (a flat box: queries from cubes beyond the grid); a coarse sphere (edges about 2.6) with a
  // fine cavity off its centre (about 0.16: where s comes from a cavity vertex farther than the nearest outer one)
  // and a small sphere far off.
  Sphere ellipsoid = icosphere(10.0, 4, false, 0.2, 7);
  for (auto& p : ellipsoid.points) p *= glm::dvec3(1.0, 0.7, 0.35);
  Sphere fine = icosphere(2.5, 4, true);
  for (auto& p : fine.points) p += glm::dvec3(3.0, 0.0, 0.0);
  Sphere far_one = icosphere(1.0, 2, false);
  for (auto& p : far_one.points) p += glm::dvec3(30.0, 4.0, -3.0);
  const Sphere cavity = joined(joined(icosphere(10.0, 2, false, 0.3, 3), fine), far_one);
  for (const Sphere* s : {static_cast<const Sphere*>(&ellipsoid), &cavity})
    for (const auto& options : {mesh::InteriorPointOptions{}, mesh::InteriorPointOptions{0.9, 1.2, 0.5}}) {
      const auto points = mesh::interior_points(s->points, s->triangles, options);
      CHECK(points.size() > 20);
      CHECK(points == reference_points(s->points, s->triangles, options));
    }
}

TEST_CASE("interior_points and ParityTest: a coarse sphere around a fine cavity, edges 260 times apart") {
  // The coarse sphere's 20 triangles (edges about 42) span thousands of the cavity's cells (edges about 0.16): the
  // sizing's query goes down its pyramid and the parity test lists them in its coarser levels.
  Sphere fine = icosphere(2.5, 4, true);
  for (auto& p : fine.points) p += glm::dvec3(5.0, 1.0, 0.0);
  const Sphere s = joined(icosphere(40.0, 0, false), fine);
  const mesh::InteriorPointOptions options;
  const auto points = mesh::interior_points(s.points, s.triangles, options);
  CHECK(points.size() > 100);
  CHECK(points == reference_points(s.points, s.triangles, options));

  // The parity test against every triangle by brute force (the same arithmetic: the same answer, bit for bit), on
  // points near the cavity, across the coarse sphere, and beyond it.
  glm::dvec3 lo(1e300), hi(-1e300);
  for (const auto& p : s.points) lo = glm::min(lo, p), hi = glm::max(hi, p);
  const mesh::ParityTest parity(s.points, s.triangles, 0, 0.32, lo, hi);
  const double nudge = 1e-9 * std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, 1.0});
  auto brute = [&](const glm::dvec3& q) {
    const double u = q.y + 0.7071067811865476 * nudge, v = q.z + 0.5772156649015329 * nudge;
    if (u < lo.y || v < lo.z || u > hi.y || v > hi.z) return false;
    bool in = false;
    for (const auto& t : s.triangles) {
      const glm::dvec3 &a = s.points[t[0]], &b = s.points[t[1]], &c = s.points[t[2]];
      const double d = (b.y - a.y) * (c.z - a.z) - (c.y - a.y) * (b.z - a.z);
      if (d == 0) continue;
      const double bs = ((u - a.y) * (c.z - a.z) - (c.y - a.y) * (v - a.z)) / d;
      const double bt = ((b.y - a.y) * (v - a.z) - (u - a.y) * (b.z - a.z)) / d;
      if (bs < 0 || bt < 0 || bs + bt > 1) continue;
      in ^= a.x + bs * (b.x - a.x) + bt * (c.x - a.x) > q.x;
    }
    return in;
  };
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> near(-3.0, 3.0), across(-45.0, 45.0);
  int inside = 0, mismatched = 0;
  for (int i = 0; i < 20000; ++i) {
    const glm::dvec3 q = i % 2 ? glm::dvec3(5.0 + near(rng), 1.0 + near(rng), near(rng))
                               : glm::dvec3(across(rng), across(rng), across(rng));
    const bool in = parity.inside(q);
    inside += in;
    mismatched += in != brute(q);
  }
  CHECK(mismatched == 0);
  CHECK(inside > 5000);
  CHECK(!parity.inside({5.0, 1.0, 0.0}));  // in the cavity
  CHECK(parity.inside({5.0, 1.0, 3.0}));   // just above it
  CHECK(parity.inside({-20.0, 0.0, 0.0}));
  CHECK(!parity.inside({0.0, 0.0, 39.0}));  // beyond the coarse sphere's flat face (its icosahedron: inradius 30)
}

TEST_CASE("interior_points: inside a sphere, clear of its vertices by the sizing, graded, the same on any thread count") {
  const Sphere s = icosphere(10.0, 4, false);  // edges about 0.66
  const mesh::InteriorPointOptions options;
  const auto points = mesh::interior_points(s.points, s.triangles, options);
  REQUIRE(points.size() > 100);
  const Sizing sizing(s.points, s.triangles);
  double near_spacing = 0, far_spacing = 0;
  size_t near = 0, far = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const glm::dvec3& p = points[i];
    // Inside the polyhedron (convex): behind every face's plane, not merely inside the circumscribed sphere.
    bool behind_all = true;
    for (const auto& t : s.triangles) {
      const glm::dvec3 &a = s.points[t[0]], &b = s.points[t[1]], &c = s.points[t[2]];
      behind_all = behind_all && glm::dot(glm::cross(b - a, c - a), p - a) < 0;
    }
    CHECK(behind_all);
    double size, d;
    sizing.at(p, options.grading, size, d);
    CHECK(d >= options.clearance * size);
    // Graded: the points a voxel-sized cube apart near the surface, farther apart deep inside.
    const double r = glm::length(p), gap = nearest_other(points, i);
    if (r > 8.5) near_spacing += gap, ++near;
    if (r < 6.0) far_spacing += gap, ++far;
  }
  REQUIRE(near > 0);
  REQUIRE(far > 0);
  CHECK(far_spacing / double(far) > 1.5 * near_spacing / double(near));
  // No hole in the middle: a point lies within the sizing at the centre.
  double centre_size, centre_distance;
  sizing.at(glm::dvec3(0.0), options.grading, centre_size, centre_distance);
  double closest = std::numeric_limits<double>::infinity();
  for (const auto& p : points) closest = std::min(closest, glm::length(p));
  CHECK(closest < centre_size);
  // A faster growth makes fewer points; every point stays clear.
  mesh::InteriorPointOptions coarse = options;
  coarse.grading = 1.0;
  CHECK(mesh::interior_points(s.points, s.triangles, coarse).size() < points.size() / 2);
  // The same points on one thread.
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  CHECK(mesh::interior_points(s.points, s.triangles, options) == points);
}

TEST_CASE("interior_points: between nested spheres only; unused points ignored; no triangles, no points; bad options refused") {
  const Sphere shell = joined(icosphere(10.0, 3, false), icosphere(5.0, 3, true));
  const std::vector<glm::dvec3>& P = shell.points;
  const std::vector<std::array<uint32_t, 3>>& T = shell.triangles;
  const auto points = mesh::interior_points(P, T);
  REQUIRE(points.size() > 20);
  for (const auto& p : points) {
    CHECK(glm::length(p) > 5.0);
    CHECK(glm::length(p) < 10.0);
  }
  // Points no triangle uses (far away, or inside) change nothing.
  std::vector<glm::dvec3> more = P;
  more.push_back({100, 0, 0});
  more.push_back({0, 0, 0});
  CHECK(mesh::interior_points(more, T) == points);
  CHECK(mesh::interior_points(P, {}).empty());
  mesh::InteriorPointOptions bad;
  bad.grading = 0.4;  // x cell 2 < 1: a cube could need splitting with no vertex within the search's reach
  CHECK_THROWS_AS(mesh::interior_points(P, T, bad), std::invalid_argument);
  bad = {};
  bad.clearance = 0;  // a point could fall on a surface vertex
  CHECK_THROWS_AS(mesh::interior_points(P, T, bad), std::invalid_argument);
  // A vertex whose edges have no length (a collapsed component): no points rather than cubes split to rounding.
  std::vector<glm::dvec3> collapsed = P;
  const uint32_t at = uint32_t(collapsed.size());
  collapsed.insert(collapsed.end(), 4, glm::dvec3(1.0, 7.0, 0.0));
  std::vector<std::array<uint32_t, 3>> with_collapsed = T;
  for (const auto& t : std::vector<std::array<uint32_t, 3>>{{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}})
    with_collapsed.push_back({at + t[0], at + t[1], at + t[2]});
  CHECK(mesh::interior_points(collapsed, with_collapsed).empty());
}

TEST_CASE("constrained_quality with interior points: the surface kept, the points meshed, the sphere filled") {
  const Sphere s = icosphere(10.0, 4, false);
  const auto interior = mesh::interior_points(s.points, s.triangles);
  mesh::QualityOptions options;
  const mesh::Tets with = mesh::constrained_quality(s.points, s.triangles, {}, {}, options, {}, interior);
  const mesh::Tets without = mesh::constrained_quality(s.points, s.triangles, {}, {}, options);
  REQUIRE(with.points.size() >= s.points.size() + interior.size());
  CHECK(std::equal(s.points.begin(), s.points.end(), with.points.begin()));
  // Every interior point is a vertex of the mesh (TetGen's refinement only adds points).
  std::set<std::array<double, 3>> made;
  for (size_t i = s.points.size(); i < with.points.size(); ++i) made.insert({with.points[i].x, with.points[i].y, with.points[i].z});
  for (const auto& p : interior) CHECK(made.count({p.x, p.y, p.z}) == 1);
  double volume = 0;
  for (const auto& t : with.tets) volume += test::tet_volume(with.points, t);
  CHECK(volume == doctest::Approx(enclosed_volume(s.points, s.triangles)).epsilon(1e-9));
  // About the tets TetGen makes from the surface alone, meeting the same radius-edge bound.
  CHECK(double(with.tets.size()) > 0.9 * double(without.tets.size()));
  CHECK(double(with.tets.size()) < 1.2 * double(without.tets.size()));
  auto above = [](const mesh::Tets& m) {
    size_t n = 0;
    for (const auto& t : m.tets)
      n += mesh::radius_edge_ratio(m.points[t[0]], m.points[t[1]], m.points[t[2]], m.points[t[3]]) > 1.5 + 1e-9;
    return n;
  };
  INFO("tets over the bound: ", above(with), " with, ", above(without), " without, of ", with.tets.size());
  CHECK(above(with) <= above(without) + with.tets.size() / 100);
}
