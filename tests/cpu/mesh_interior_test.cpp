// Interior points for TetGen (interior_points.h): inside the surfaces, clear of them by the sizing, graded, the same
// on any thread count, and what TetGen makes of them.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>

#include <tbb/global_control.h>

#include "icosphere.h"
#include "mesh/interior_points.h"
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

}  // namespace

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
    CHECK(glm::length(p) < 10.0);
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
  const Sphere outer = icosphere(10.0, 3, false), inner = icosphere(5.0, 3, true);
  std::vector<glm::dvec3> P = outer.points;
  std::vector<std::array<uint32_t, 3>> T = outer.triangles;
  for (auto t : inner.triangles) {
    for (auto& v : t) v += uint32_t(outer.points.size());
    T.push_back(t);
  }
  P.insert(P.end(), inner.points.begin(), inner.points.end());
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
  bad.clearance = -1;
  CHECK_THROWS_AS(mesh::interior_points(P, T, bad), std::invalid_argument);
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
