// The last sliver pass (remesh_slivers.h): cavities around slivers meshed afresh by TetGen, their boundary kept.
#include <doctest/doctest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>

#include "mesh/quality.h"
#include "mesh/remesh_slivers.h"
#include "mesh/smooth.h"

using namespace cpmesh;

namespace {

double volume_of(const std::vector<glm::dvec3>& P, const std::vector<std::array<uint32_t, 4>>& tets) {
  double v = 0;
  for (const auto& t : tets) v += mesh::tet_volume(P[t[0]], P[t[1]], P[t[2]], P[t[3]]);
  return v;
}

double signed_volume(const std::vector<glm::dvec3>& P, const std::array<uint32_t, 4>& t) {
  return glm::dot(P[t[1]] - P[t[0]], glm::cross(P[t[2]] - P[t[0]], P[t[3]] - P[t[0]]));
}

std::map<std::array<uint32_t, 3>, int> face_counts(const std::vector<std::array<uint32_t, 4>>& tets) {
  std::map<std::array<uint32_t, 3>, int> n;
  for (const auto& t : tets)
    for (int c = 0; c < 4; ++c) {
      std::array<uint32_t, 3> f = {t[size_t((c + 1) % 4)], t[size_t((c + 2) % 4)], t[size_t((c + 3) % 4)]};
      std::sort(f.begin(), f.end());
      ++n[f];
    }
  return n;
}

// The points of an n^3 cube's surface on the unit grid, and its triangles (two per unit square: the hull faces of
// their Delaunay tets).
void cube_surface(int n, std::vector<glm::dvec3>& P, std::vector<std::array<uint32_t, 3>>& triangles) {
  for (int z = 0; z <= n; ++z)
    for (int y = 0; y <= n; ++y)
      for (int x = 0; x <= n; ++x)
        if (x == 0 || y == 0 || z == 0 || x == n || y == n || z == n) P.push_back({x, y, z});
  for (const auto& [f, count] : face_counts(mesh::delaunay(P).tets))
    if (count == 1) triangles.push_back(f);
}

}  // namespace

TEST_CASE("remesh_slivers: the slivers of a jittered lattice's Delaunay tets go, the cube's surface stays as it was") {
  // A 6^3 cube: its surface points on a unit grid first (fixed), then the inner lattice points, jittered. The
  // Delaunay tets of a near-lattice are full of slivers (cospherical groups of eight); the hull faces are kept.
  std::vector<glm::dvec3> P;
  std::vector<std::array<uint32_t, 3>> surface;
  cube_surface(6, P, surface);
  const size_t fixed = P.size();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  for (int z = 1; z < 6; ++z)
    for (int y = 1; y < 6; ++y)
      for (int x = 1; x < 6; ++x) P.push_back({x + u(rng), y + u(rng), z + u(rng)});
  mesh::Tets T = mesh::delaunay(P);
  std::vector<std::array<uint32_t, 3>> kept;
  for (const auto& [f, n] : face_counts(T.tets))
    if (n == 1) kept.push_back(f);
  std::sort(surface.begin(), surface.end());
  REQUIRE(kept == surface);
  std::vector<int> region(T.tets.size(), 5);
  mesh::QualityOptions options;
  const size_t before = mesh::count_below_dihedral(T.points, T.tets, options.min_dihedral);
  REQUIRE(before > 20);
  const bool positive = signed_volume(T.points, T.tets[0]) > 0;

  std::vector<glm::dvec3> points = T.points;
  std::vector<std::array<uint32_t, 4>> tets = T.tets;
  const auto r = mesh::remesh_slivers(points, tets, region, kept, fixed, options);
  MESSAGE(before << " slivers, " << r.cavities << " cavities, " << r.remeshed << " remeshed; "
                 << mesh::count_below_dihedral(points, tets, options.min_dihedral) << " left, " << tets.size()
                 << " tets from " << T.tets.size());
  CHECK(r.slivers == before);
  CHECK(r.remeshed >= 1);
  CHECK(r.tetgen_failures == 0);
  CHECK(mesh::count_below_dihedral(points, tets, options.min_dihedral) == 0);
  CHECK(volume_of(points, tets) == doctest::Approx(216.0).epsilon(1e-12));
  CHECK(region.size() == tets.size());
  CHECK(std::all_of(region.begin(), region.end(), [](int x) { return x == 5; }));
  // The fixed points unmoved; every other point in some tet; one handedness.
  CHECK(std::equal(P.begin(), P.begin() + std::ptrdiff_t(fixed), points.begin()));
  std::vector<uint8_t> used(points.size(), 0);
  for (const auto& t : tets)
    for (uint32_t v : t) used[v] = 1;
  CHECK(std::all_of(used.begin() + std::ptrdiff_t(fixed), used.end(), [](uint8_t x) { return x == 1; }));
  CHECK(std::all_of(tets.begin(), tets.end(), [&](const auto& t) { return (signed_volume(points, t) > 0) == positive; }));
  // Conforming: the hull faces are those kept, once each; every other face twice.
  std::map<std::array<uint32_t, 3>, int> expect;
  for (auto f : kept) expect[f] = 1;
  size_t wrong = 0;
  for (const auto& [f, n] : face_counts(tets)) wrong += n != (expect.count(f) ? 1 : 2);
  CHECK(wrong == 0);
  size_t hull = 0;
  for (const auto& [f, n] : face_counts(tets)) hull += n == 1;
  CHECK(hull == kept.size());

  // Deterministic.
  std::vector<glm::dvec3> points2 = T.points;
  std::vector<std::array<uint32_t, 4>> tets2 = T.tets;
  std::vector<int> region2(T.tets.size(), 5);
  mesh::remesh_slivers(points2, tets2, region2, kept, fixed, options);
  CHECK(points2 == points);
  CHECK(tets2 == tets);
}

TEST_CASE("remesh_slivers: three slivers in a quality mesh are mended locally; the tets far from them stay") {
  // TetGen's quality mesh of a 10^3 cube (its few slivers moved away); three inner vertices far apart are pushed towards the opposite face of one
  // of their tets until it is flat (no tet turned over). Each sliver's cavity is meshed afresh; the rest is untouched.
  std::vector<glm::dvec3> surface_points;
  std::vector<std::array<uint32_t, 3>> box;
  cube_surface(10, surface_points, box);
  mesh::QualityOptions options;
  options.max_volume = 0.3;
  const mesh::Tets T = mesh::constrained_quality(surface_points, box, {}, {{glm::dvec3(5.0), 1}}, options);
  options.max_volume = 0;
  std::vector<glm::dvec3> P = T.points;
  std::vector<std::array<uint32_t, 4>> tets = T.tets;
  std::vector<int> region = T.region;
  std::vector<std::array<uint32_t, 3>> kept;
  for (const auto& [f, n] : face_counts(tets))
    if (n == 1) kept.push_back(f);
  const size_t fixed = surface_points.size();
  mesh::improve_tets(P, tets, fixed);  // the few slivers TetGen leaves
  REQUIRE(mesh::count_below_dihedral(P, tets, 12.0) == 0);
  const bool positive = signed_volume(P, tets[0]) > 0;
  std::vector<uint32_t> moved;
  for (const glm::dvec3 target : {glm::dvec3(2.5), glm::dvec3(7.5, 2.5, 7.5), glm::dvec3(2.5, 7.5, 7.5)}) {
    uint32_t v = fixed;  // the inner vertex nearest the target
    for (uint32_t w = fixed; w < P.size(); ++w)
      if (glm::length(P[w] - target) < glm::length(P[v] - target)) v = w;
    bool done = false;
    for (size_t t = 0; t < tets.size() && !done; ++t) {
      const auto& k = tets[t];
      const auto at = std::find(k.begin(), k.end(), v);
      if (at == k.end()) continue;
      std::array<glm::dvec3, 3> f;
      int n = 0;
      for (uint32_t w : k)
        if (w != v) f[size_t(n++)] = P[w];
      const glm::dvec3 normal = glm::normalize(glm::cross(f[1] - f[0], f[2] - f[0]));
      const glm::dvec3 old = P[v];
      P[v] -= 0.95 * glm::dot(P[v] - f[0], normal) * normal;  // 5% of its height left
      bool valid = true;
      for (const auto& q : tets)
        if (std::find(q.begin(), q.end(), v) != q.end()) valid = valid && (signed_volume(P, q) > 0) == positive;
      if (valid && mesh::dihedral_range(P[k[0]], P[k[1]], P[k[2]], P[k[3]])[0] < 8 * M_PI / 180) {
        done = true;
        moved.push_back(v);
      } else {
        P[v] = old;
      }
    }
  }
  REQUIRE(moved.size() == 3);
  const size_t before = mesh::count_below_dihedral(P, tets, options.min_dihedral);
  REQUIRE(before >= 3);
  MESSAGE(P.size() << " points, " << tets.size() << " tets");
  const auto old_points = P;
  const auto old_tets = tets;
  const auto r = mesh::remesh_slivers(P, tets, region, kept, fixed, options);
  MESSAGE(before << " slivers, " << r.cavities << " cavities, " << r.remeshed << " remeshed; " << tets.size()
                 << " tets from " << old_tets.size() << ", " << r.points_removed << " points removed");
  CHECK(r.cavities == 3);
  CHECK(r.remeshed == 3);
  CHECK(mesh::count_below_dihedral(P, tets, options.min_dihedral) == 0);
  CHECK(volume_of(P, tets) == doctest::Approx(1000.0).epsilon(1e-12));
  // Away from the moved vertices (beyond 4 units) the same tets at the same places.
  auto far = [&](const std::vector<glm::dvec3>& Q, const std::array<uint32_t, 4>& t) {
    const glm::dvec3 c = (Q[t[0]] + Q[t[1]] + Q[t[2]] + Q[t[3]]) / 4.0;
    return std::all_of(moved.begin(), moved.end(), [&](uint32_t v) { return glm::length(c - old_points[v]) > 4.0; });
  };
  std::multiset<std::array<double, 3>> far_before, far_after;
  for (const auto& t : old_tets)
    if (far(old_points, t)) {
      const glm::dvec3 c = (old_points[t[0]] + old_points[t[1]] + old_points[t[2]] + old_points[t[3]]) / 4.0;
      far_before.insert({c.x, c.y, c.z});
    }
  for (const auto& t : tets)
    if (far(P, t)) {
      const glm::dvec3 c = (P[t[0]] + P[t[1]] + P[t[2]] + P[t[3]]) / 4.0;
      far_after.insert({c.x, c.y, c.z});
    }
  CHECK(far_before.size() > old_tets.size() / 4);
  CHECK(far_after == far_before);
  size_t wrong = 0;
  std::map<std::array<uint32_t, 3>, int> expect;
  for (auto f : kept) expect[f] = 1;
  for (const auto& [f, n] : face_counts(tets)) wrong += n != (expect.count(f) ? 1 : 2);
  CHECK(wrong == 0);
}

TEST_CASE("remesh_slivers: a sliver walled in by kept faces is left as it is") {
  // Its four faces kept: the cavity is the sliver alone, and no mesh of it without points on its faces is better.
  std::vector<glm::dvec3> P = {{0, 0, 0}, {2, 0, 0}, {1, 1.7, 0.1}, {1, 0.6, 0.12}};
  std::vector<std::array<uint32_t, 4>> tets = {{0, 1, 2, 3}};
  std::vector<int> region = {3};
  const std::vector<std::array<uint32_t, 3>> kept = {{0, 1, 2}, {0, 1, 3}, {0, 2, 3}, {1, 2, 3}};
  const auto r = mesh::remesh_slivers(P, tets, region, kept, 4, mesh::QualityOptions{});
  CHECK(r.slivers == 1);
  CHECK(r.cavities == 1);
  CHECK(r.remeshed == 0);
  CHECK(P.size() == 4);
  CHECK(tets == std::vector<std::array<uint32_t, 4>>{{0, 1, 2, 3}});
  CHECK(region == std::vector<int>{3});
}
