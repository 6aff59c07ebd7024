// The last sliver pass (remesh_slivers.h): cavities around slivers meshed afresh by TetGen, their boundary kept; and
// drop_pockets (volume_mesh.h), which a material's piece uses for regions its boundary closes off from outside.
#include <doctest/doctest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>
#include <stdexcept>
#include <tuple>

#include "mesh/quality.h"
#include "mesh/remesh_slivers.h"
#include "mesh/smooth.h"
#include "mesh/volume_mesh.h"

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

// Pushes the free vertex (>= fixed) nearest `target` towards the opposite face of one of its tets until that tet is
// flat (under 8 degrees; 5% of its height left), turning no tet over. Returns the vertex, or UINT32_MAX.
uint32_t flatten_near(std::vector<glm::dvec3>& P, const std::vector<std::array<uint32_t, 4>>& tets, size_t fixed,
                      const glm::dvec3& target) {
  const bool positive = signed_volume(P, tets[0]) > 0;
  auto v = uint32_t(fixed);
  for (auto w = uint32_t(fixed); w < P.size(); ++w)
    if (glm::length(P[w] - target) < glm::length(P[v] - target)) v = w;
  for (const auto& k : tets) {
    if (std::find(k.begin(), k.end(), v) == k.end()) continue;
    std::array<glm::dvec3, 3> f;
    int n = 0;
    for (uint32_t w : k)
      if (w != v) f[size_t(n++)] = P[w];
    const glm::dvec3 normal = glm::normalize(glm::cross(f[1] - f[0], f[2] - f[0]));
    const glm::dvec3 old = P[v];
    P[v] -= 0.95 * glm::dot(P[v] - f[0], normal) * normal;
    bool valid = true;
    for (const auto& q : tets)
      if (std::find(q.begin(), q.end(), v) != q.end()) valid = valid && (signed_volume(P, q) > 0) == positive;
    if (valid && mesh::dihedral_range(P[k[0]], P[k[1]], P[k[2]], P[k[3]])[0] < 8 * M_PI / 180) return v;
    P[v] = old;
  }
  return UINT32_MAX;
}

// The unit-grid triangles of the n^3 cube's surface and of the inner planes x = c for c in `planes` (two per unit
// square), over shared points.
void grid_surfaces(int n, const std::vector<int>& planes, std::vector<glm::dvec3>& P,
                   std::vector<std::array<uint32_t, 3>>& triangles) {
  std::map<std::array<int, 3>, uint32_t> id;
  auto at = [&](std::array<int, 3> q) {
    const auto [it, fresh] = id.try_emplace(q, uint32_t(P.size()));
    if (fresh) P.push_back({q[0], q[1], q[2]});
    return it->second;
  };
  auto square_grid = [&](int axis, int c) {  // the plane `axis` = c, squares along the other two axes
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        std::array<uint32_t, 4> q;
        const int du[4] = {0, 1, 1, 0}, dv[4] = {0, 0, 1, 1};
        for (int k = 0; k < 4; ++k) {
          std::array<int, 3> x;
          x[size_t(axis)] = c;
          x[size_t((axis + 1) % 3)] = i + du[k];
          x[size_t((axis + 2) % 3)] = j + dv[k];
          q[size_t(k)] = at(x);
        }
        triangles.push_back({q[0], q[1], q[2]});
        triangles.push_back({q[0], q[2], q[3]});
      }
  };
  for (int axis = 0; axis < 3; ++axis) {
    square_grid(axis, 0);
    square_grid(axis, n);
  }
  for (int c : planes) square_grid(0, c);
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
  // TetGen's quality mesh of a 10^3 cube (its few slivers moved away); three inner vertices far apart are pushed
  // towards the opposite face of one of their tets until it is flat (no tet turned over). Each sliver's cavity is meshed afresh; the rest is untouched.
  std::vector<glm::dvec3> surface_points;
  std::vector<std::array<uint32_t, 3>> box;
  cube_surface(10, surface_points, box);
  mesh::QualityOptions options;
  options.max_volume = 0.3;
  // The mesh this test was written on: TetGen's own dihedral refinement. Without it (the materials' runs) the mesh is
  // coarser; its cavities then reach past the 4 units checked below, and 3 of its 7 slivers stayed.
  options.dihedral_in_tetgen = true;
  const mesh::Tets T = mesh::constrained_quality(surface_points, box, {}, {{glm::dvec3(5.0), 1}}, options);
  options.max_volume = 0;
  options.dihedral_in_tetgen = false;
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
  CHECK(positive == (signed_volume(T.points, T.tets[0]) > 0));
  std::vector<uint32_t> moved;
  for (const glm::dvec3 target : {glm::dvec3(2.5), glm::dvec3(7.5, 2.5, 7.5), glm::dvec3(2.5, 7.5, 7.5)}) {
    const uint32_t v = flatten_near(P, tets, fixed, target);
    if (v != UINT32_MAX) moved.push_back(v);
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

  // One TetGen run per cavity (the new points of later runs numbered after the earlier runs'): as good, as exact.
  std::vector<glm::dvec3> P1 = old_points;
  std::vector<std::array<uint32_t, 4>> tets1 = old_tets;
  std::vector<int> region1 = T.region;
  const auto r1 = mesh::remesh_slivers(P1, tets1, region1, kept, fixed, options, 3, 1);
  CHECK(r1.remeshed == 3);
  CHECK(mesh::count_below_dihedral(P1, tets1, options.min_dihedral) == 0);
  CHECK(volume_of(P1, tets1) == doctest::Approx(1000.0).epsilon(1e-12));
  size_t wrong1 = 0;
  for (const auto& [f, n] : face_counts(tets1)) wrong1 += n != (expect.count(f) ? 1 : 2);
  CHECK(wrong1 == 0);
  std::vector<uint8_t> used(P1.size(), 0);
  for (const auto& t : tets1)
    for (uint32_t v : t) used[v] = 1;
  CHECK(std::all_of(used.begin() + std::ptrdiff_t(fixed), used.end(), [](uint8_t x) { return x == 1; }));

  // TetGen giving up on every run of more than one cavity: the three are halved down to single runs ({0 1 2} fails,
  // {0} goes, {1 2} fails, {1} and {2} go), in the order of one run per cavity, so the same mesh as above.
  std::vector<glm::dvec3> P2 = old_points;
  std::vector<std::array<uint32_t, 4>> tets2 = old_tets;
  std::vector<int> region2 = T.region;
  std::vector<size_t> runs;
  const auto r2 = mesh::remesh_slivers(P2, tets2, region2, kept, fixed, options, 3, 0, [&](size_t cavities) {
    runs.push_back(cavities);
    if (cavities > 1) throw std::runtime_error("TetGen gave up");
  });
  CHECK(runs == std::vector<size_t>{3, 1, 2, 1, 1});
  CHECK(r2.tetgen_failures == 2);
  CHECK(r2.remeshed == 3);
  CHECK(P2 == P1);
  CHECK(tets2 == tets1);
  CHECK(region2 == region1);
}

TEST_CASE("remesh_slivers: slivers beside a kept interface between two regions: the interface and the regions stay") {
  // The 10^3 cube in two regions split by the kept plane x = 5; slivers pushed flat right beside the plane on both
  // sides. A cavity must neither cross the plane nor take a tet of the other region.
  std::vector<glm::dvec3> surface_points;
  std::vector<std::array<uint32_t, 3>> surface;
  grid_surfaces(10, {5}, surface_points, surface);
  mesh::QualityOptions options;
  options.max_volume = 0.3;
  const mesh::Tets T = mesh::constrained_quality(surface_points, surface, {},
                                                 {{glm::dvec3(2.5, 5, 5), 1}, {glm::dvec3(7.5, 5, 5), 2}}, options);
  options.max_volume = 0;
  std::vector<glm::dvec3> P = T.points;
  std::vector<std::array<uint32_t, 4>> tets = T.tets;
  std::vector<int> region = T.region;
  const size_t fixed = surface_points.size();
  mesh::improve_tets(P, tets, fixed);
  REQUIRE(mesh::count_below_dihedral(P, tets, 12.0) == 0);
  size_t flattened = 0;
  for (const glm::dvec3 target : {glm::dvec3(4.6, 2.5, 2.5), glm::dvec3(5.4, 2.5, 7.5), glm::dvec3(4.6, 7.5, 5.0),
                                  glm::dvec3(5.4, 7.5, 2.0)})
    flattened += flatten_near(P, tets, fixed, target) != UINT32_MAX;
  REQUIRE(flattened == 4);
  const size_t before = mesh::count_below_dihedral(P, tets, options.min_dihedral);
  const auto r = mesh::remesh_slivers(P, tets, region, surface, fixed, options);
  MESSAGE(before << " slivers, " << r.cavities << " cavities, " << r.remeshed << " remeshed; "
                 << mesh::count_below_dihedral(P, tets, options.min_dihedral) << " left");
  CHECK(r.remeshed >= 3);
  CHECK(mesh::count_below_dihedral(P, tets, options.min_dihedral) < before);
  REQUIRE(region.size() == tets.size());
  std::map<int, double> volume;
  std::map<std::array<uint32_t, 3>, std::multiset<int>> sides;
  for (size_t t = 0; t < tets.size(); ++t) {
    const auto& k = tets[t];
    volume[region[t]] += mesh::tet_volume(P[k[0]], P[k[1]], P[k[2]], P[k[3]]);
    for (int c = 0; c < 4; ++c) {
      std::array<uint32_t, 3> f = {k[size_t((c + 1) % 4)], k[size_t((c + 2) % 4)], k[size_t((c + 3) % 4)]};
      std::sort(f.begin(), f.end());
      sides[f].insert(region[t]);
    }
  }
  CHECK(volume.size() == 2);
  CHECK(volume[1] == doctest::Approx(500.0).epsilon(1e-12));
  CHECK(volume[2] == doctest::Approx(500.0).epsilon(1e-12));
  // Every triangle of the plane between a tet of each region; every other face of one region only.
  size_t plane = 0, wrong = 0;
  for (const auto& [f, who] : sides) {
    const bool on_plane = P[f[0]].x == 5 && P[f[1]].x == 5 && P[f[2]].x == 5;
    plane += on_plane;
    wrong += on_plane ? who != std::multiset<int>{1, 2} : (who.size() == 2 && *who.begin() != *who.rbegin());
  }
  CHECK(plane == 200);
  CHECK(wrong == 0);
  CHECK(std::equal(surface_points.begin(), surface_points.end(), P.begin()));
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

TEST_CASE("drop_pockets: a region the boundary closes off from outside goes, the material stays") {
  // A 10^3 box with a 2^3 cube inside that is not the material (another material's cavity with no hole seed): the
  // boundary runs out of the material, so the inner cube's triangles face into it. TetGen without seeds meshes both
  // regions; the inner one must go.
  std::vector<glm::dvec3> P;
  std::vector<std::array<uint32_t, 3>> boundary;
  const std::vector<std::array<uint32_t, 3>> box = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                                                    {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
  for (const auto& [lo, hi, outward] : {std::tuple{0.0, 10.0, true}, std::tuple{4.0, 6.0, false}}) {
    const auto base = uint32_t(P.size());
    for (int k = 0; k < 8; ++k)
      P.push_back({(k == 1 || k == 2 || k == 5 || k == 6) ? hi : lo, (k == 2 || k == 3 || k == 6 || k == 7) ? hi : lo,
                   k >= 4 ? hi : lo});
    for (auto t : box) boundary.push_back(outward ? std::array<uint32_t, 3>{base + t[0], base + t[1], base + t[2]}
                                                  : std::array<uint32_t, 3>{base + t[0], base + t[2], base + t[1]});
  }
  mesh::QualityOptions options;
  options.keep_surface = false;  // let TetGen refine the big faces too
  mesh::Tets V = mesh::constrained_quality(P, boundary, {}, {}, options);
  REQUIRE(volume_of(V.points, V.tets) == doctest::Approx(1000.0).epsilon(1e-12));
  std::set<int> regions(V.region.begin(), V.region.end());
  REQUIRE(regions.size() == 2);
  // The boundary as TetGen split it (points on the faces): the faces between different regions or on the hull,
  // oriented out of the material.
  std::map<std::array<uint32_t, 3>, std::vector<std::pair<size_t, int>>> at;
  for (size_t t = 0; t < V.tets.size(); ++t)
    for (int c = 0; c < 4; ++c) {
      const auto& k = V.tets[t];
      std::array<uint32_t, 3> f = {k[size_t((c + 1) % 4)], k[size_t((c + 2) % 4)], k[size_t((c + 3) % 4)]};
      std::sort(f.begin(), f.end());
      at[f].push_back({t, c});
    }
  std::vector<std::array<uint32_t, 3>> faces;
  for (const auto& [f, uses] : at) {
    if (uses.size() == 2 && V.region[uses[0].first] == V.region[uses[1].first]) continue;
    const glm::dvec3 c = (V.points[f[0]] + V.points[f[1]] + V.points[f[2]]) / 3.0;
    const bool inner = std::max({std::fabs(c.x - 5), std::fabs(c.y - 5), std::fabs(c.z - 5)}) < 1.5;
    const glm::dvec3 want = inner ? glm::dvec3(5.0) - c : c - glm::dvec3(5.0);  // out of the material
    std::array<uint32_t, 3> g = f;
    if (glm::dot(glm::cross(V.points[g[1]] - V.points[g[0]], V.points[g[2]] - V.points[g[0]]), want) < 0)
      std::swap(g[1], g[2]);
    faces.push_back(g);
  }
  const size_t points_before = V.points.size();
  mesh::drop_pockets(V, faces, P.size());
  CHECK(volume_of(V.points, V.tets) == doctest::Approx(1000.0 - 8.0).epsilon(1e-12));
  CHECK(std::set<int>(V.region.begin(), V.region.end()).size() == 1);
  CHECK(V.points.size() <= points_before);
  std::vector<uint8_t> used(V.points.size(), 0);
  for (const auto& t : V.tets)
    for (uint32_t v : t) used[v] = 1;
  CHECK(std::all_of(used.begin() + std::ptrdiff_t(P.size()), used.end(), [](uint8_t x) { return x == 1; }));
}
