// mesh::smooth_interfaces on the restricted Delaunay mesh of random points on a sphere (a poor mesh on purpose):
// quality goes up, the worst triangle does not get worse, vertices stay on the surface, connectivity is unchanged.
#include <doctest/doctest.h>

#include <map>
#include <random>
#include <set>

#include <tbb/global_control.h>

#include "fields/fields_stage.h"
#include "fields_volumes.h"
#include "mesh/elements_around.h"
#include "mesh/extract.h"
#include "mesh/quality.h"
#include "mesh/smooth.h"
#include "mesh/tetgen.h"
#include "mesh/volume_mesh.h"
#include "ref/cp_lookup.h"

using namespace cpmesh;

TEST_CASE("smooth_interfaces: random points on a sphere become a better mesh on the same sphere") {
  const double R = 14;
  const auto vol = test::make_volume(io::SynthShape::sphere, 40, R);
  const auto F = fields::build_fields(vol.grid, vol.labels.data());
  const auto& E = F.embedding;
  REQUIRE(E.features.size() == 1);
  std::mt19937 rng(7);
  std::normal_distribution<double> n01;
  std::vector<glm::dvec3> points;
  while (points.size() < 400) {
    const glm::dvec3 dir = glm::normalize(glm::dvec3(n01(rng), n01(rng), n01(rng)));
    const auto cp = ref::cp_lookup(E, glm::vec3(vol.centre + R * dir), 0);
    if (cp.valid) points.push_back(glm::dvec3(glm::vec3(cp.value)));
  }
  const auto T = mesh::delaunay(points);
  const auto material = mesh::label_tets(F.fields, T);
  const auto adj = mesh::build_adjacency(T);
  const auto hull = mesh::hull_materials(F.fields, T, adj);
  auto I = mesh::extract_interfaces(T, adj, hull, material, std::vector<uint8_t>(points.size(), 2));
  REQUIRE(I.triangles.size() > 500);
  const auto triangles = I.triangles;
  const auto before = mesh::triangle_stats(I.vertices, I.triangles);
  const auto r = mesh::smooth_interfaces(F.fields, E, std::vector<uint32_t>(points.size(), 0), I);
  const auto after = mesh::triangle_stats(I.vertices, I.triangles);
  MESSAGE("radius ratio mean " << before.mean_radius_ratio << " -> " << after.mean_radius_ratio << ", min "
                               << before.min_radius_ratio << " -> " << after.min_radius_ratio << "; " << r.moves
                               << " moves, " << r.refused << " refused in " << r.rounds << " rounds");
  CHECK(r.moves > 0);
  CHECK(after.mean_radius_ratio > before.mean_radius_ratio + 0.05);
  CHECK(after.min_radius_ratio >= before.min_radius_ratio);
  CHECK(I.triangles == triangles);
  double worst = 0;
  for (const auto& p : I.vertices) worst = std::max(worst, std::fabs(glm::length(p - vol.centre) - R));
  MESSAGE("vertices: max distance to the true sphere " << worst << " voxel");
  CHECK(worst < 0.5);
  // Rounds = 0: nothing moves.
  const auto kept = I.vertices;
  mesh::SmoothOptions off;
  off.rounds = 0;
  CHECK(mesh::smooth_interfaces(F.fields, E, std::vector<uint32_t>(points.size(), 0), I, off).moves == 0);
  CHECK(I.vertices == kept);
}

TEST_CASE("build_adjacency: two tets meet on their shared face, with vertex indices past 2^21") {
  // The adjacency once packed a face into 21 bits per vertex and refused meshes of 2M points or more, while a run
  // may make up to 5M particles (MeshOptions::max_particles).
  mesh::Tets T;
  const uint32_t base = (1u << 21) + 5;
  T.points.resize(size_t(base) + 5, glm::dvec3(0.0));
  T.points[base + 0] = {0, 0, 0};
  T.points[base + 1] = {1, 0, 0};
  T.points[base + 2] = {0, 1, 0};
  T.points[base + 3] = {0, 0, 1};
  T.points[base + 4] = {0, 0, -1};
  T.tets = {{base + 0, base + 1, base + 2, base + 3}, {base + 1, base + 0, base + 2, base + 4}};
  const auto adj = mesh::build_adjacency(T);
  size_t shared = 0;
  for (uint32_t tc = 0; tc < adj.neighbour.size(); ++tc) {
    if (adj.neighbour[tc] == mesh::Adjacency::kHull) continue;
    ++shared;
    CHECK(adj.neighbour[tc] / 4 != tc / 4);
    CHECK(adj.neighbour[adj.neighbour[tc]] == tc);
    CHECK(T.tets[tc / 4][tc % 4] == (tc / 4 == 0 ? base + 3 : base + 4));  // the face opposite the apex
  }
  CHECK(shared == 2);
}

TEST_CASE("build_adjacency: TetGen's neighbours give the same adjacency as sorting the faces") {
  // 3000 random points with one duplicate (delaunay() drops it and renumbers): the linear path from the neighbours
  // TetGen reports must match the sort of every tet face, slot for slot.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 10.0);
  std::vector<glm::dvec3> points;
  for (int i = 0; i < 3000; ++i) points.push_back({u(rng), u(rng), u(rng)});
  points.push_back(points[17]);
  const auto T = mesh::delaunay(points);
  REQUIRE(T.neighbours.size() == T.tets.size() * 4);
  auto sorted = T;
  sorted.neighbours.clear();
  const auto fast = mesh::build_adjacency(T), slow = mesh::build_adjacency(sorted);
  CHECK(fast.neighbour == slow.neighbour);
  const size_t hull = size_t(std::count(slow.neighbour.begin(), slow.neighbour.end(), mesh::Adjacency::kHull));
  CHECK(hull > 100);
  CHECK(hull < slow.neighbour.size() / 10);
}

TEST_CASE("hull_materials: a coarse hull under a curved surface still sees the outside material") {
  // An icosahedron on a sphere of radius 10 voxels: its faces lie up to 2 voxels inside the sphere, so half a voxel
  // beyond them is still the sphere's material. Every hull face must see the background instead, or the sphere's
  // boundary (the faces between its tets and the outside) has holes.
  const double R = 10;
  const auto vol = test::make_volume(io::SynthShape::sphere, 32, R);
  const auto F = fields::build_indicator_fields(vol.grid, vol.labels.data());
  const double g = (1 + std::sqrt(5.0)) / 2;
  std::vector<glm::dvec3> points;
  for (int s1 : {-1, 1})
    for (int s2 : {-1, 1})
      for (const glm::dvec3& d : {glm::dvec3(0, s1, s2 * g), glm::dvec3(s1, s2 * g, 0), glm::dvec3(s2 * g, 0, s1)})
        points.push_back(vol.centre + R * glm::normalize(d));
  const auto T = mesh::delaunay(points);
  const auto material = mesh::label_tets(F, T);
  const auto adj = mesh::build_adjacency(T);
  const auto hull = mesh::hull_materials(F, T, adj);
  size_t faces = 0, outside = 0;
  for (uint32_t tc = 0; tc < adj.neighbour.size(); ++tc) {
    if (adj.neighbour[tc] != mesh::Adjacency::kHull) continue;
    ++faces;
    outside += hull[tc] == 0;  // labels ascending: the background (0) is material 0, the sphere material 1
  }
  CHECK(faces == 20);
  CHECK(outside == faces);
  for (uint16_t m : material) CHECK(m == 1);
  const auto I = mesh::extract_interfaces(T, adj, hull, material, std::vector<uint8_t>(points.size(), 2));
  CHECK(I.triangles.size() == 20);
  CHECK(mesh::odd_edges(I.triangles) == 0);
}

TEST_CASE("improve_tets: a free vertex near a face of a cube moves back inside, fixed vertices stay") {
  // A unit cube, each face split in two triangles, each triangle joined to one free vertex (index 8) put almost on
  // the bottom face: the two bottom tets are slivers.
  std::vector<glm::dvec3> P;
  for (int c = 0; c < 8; ++c) P.push_back(glm::dvec3(c & 1, (c >> 1) & 1, (c >> 2) & 1));
  P.push_back(glm::dvec3(0.45, 0.55, 0.02));
  const int faces[6][4] = {{0, 1, 3, 2}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 3, 7, 5}};
  std::vector<std::array<uint32_t, 4>> tets;
  for (const auto& f : faces) {
    tets.push_back({uint32_t(f[0]), uint32_t(f[1]), uint32_t(f[2]), 8});
    tets.push_back({uint32_t(f[0]), uint32_t(f[2]), uint32_t(f[3]), 8});
  }
  const auto corners = std::vector<glm::dvec3>(P.begin(), P.begin() + 8);
  const auto r = mesh::improve_tets(P, tets, 8, 12.0);
  MESSAGE("min dihedral " << r.min_dihedral_before << " -> " << r.min_dihedral_after << " deg, vertex at " << P[8].x
                          << " " << P[8].y << " " << P[8].z);
  CHECK(r.min_dihedral_before < 5);
  CHECK(r.min_dihedral_after > 30);
  CHECK(r.moves > 0);
  CHECK(std::vector<glm::dvec3>(P.begin(), P.begin() + 8) == corners);
  CHECK(mesh::tet_stats(P, tets).min_dihedral_deg == doctest::Approx(r.min_dihedral_after));
  // Nothing below the target: nothing moves.
  const auto settled = P;
  CHECK(mesh::improve_tets(P, tets, 8, 1.0).moves == 0);
  CHECK(P == settled);
}

namespace {

// Six times the signed volume of tet t.
double orient(const std::vector<glm::dvec3>& P, const std::array<uint32_t, 4>& t) {
  return glm::dot(P[t[1]] - P[t[0]], glm::cross(P[t[2]] - P[t[0]], P[t[3]] - P[t[0]]));
}

// Gives every tet the first one's orientation, as a mesher does; returns whether that is positive, and the total
// volume (times six).
std::pair<bool, double> orient_like_first(const std::vector<glm::dvec3>& P, std::vector<std::array<uint32_t, 4>>& tets) {
  for (auto& t : tets)
    if ((orient(P, t) > 0) != (orient(P, tets[0]) > 0)) std::swap(t[0], t[1]);
  double volume = 0;
  for (const auto& t : tets) volume += std::fabs(orient(P, t));
  return {orient(P, tets[0]) > 0, volume};
}

}  // namespace

TEST_CASE("split_slivers: a flat tet between two kept triangles is refilled around one new vertex") {
  // Two kept triangles abc and abd fold into a shallow valley along ab; the flat tet abcd fills the valley, and two
  // tets join its top faces to a vertex e above. No vertex can move (all five are kept), so only a new one helps.
  std::vector<glm::dvec3> P = {{0, 0, 0}, {0, 2, 0}, {-1.5, 1, 0.12}, {1.5, 1, 0.12}, {0, 1, 1.5}};
  const uint32_t a = 0, b = 1, c = 2, d = 3, e = 4;
  std::vector<std::array<uint32_t, 4>> tets = {{a, b, c, d}, {a, c, d, e}, {b, d, c, e}};
  const auto [positive, volume] = orient_like_first(P, tets);
  std::vector<int> region = {7, 7, 7};
  const std::vector<std::array<uint32_t, 3>> kept = {{a, b, c}, {a, b, d}};
  const double before = mesh::tet_stats(P, tets).min_dihedral_deg;

  auto untouched = tets;
  auto untouched_region = region;
  CHECK(mesh::split_slivers(P, untouched, untouched_region, kept, 1.0).inserted == 0);  // nothing below 1 degree
  CHECK(untouched == tets);
  {  // Edge removal finds the same fix with no new vertex: the three tets on edge cd become abec and abed.
    auto flipped = tets;
    auto flipped_region = region;
    auto Q = P;
    const auto f = mesh::split_slivers(Q, flipped, flipped_region, kept, 20.0);
    CHECK(f.flips == 1);
    CHECK(f.inserted == 0);
    CHECK(Q == P);
    CHECK(flipped.size() == 2);
    CHECK(mesh::tet_stats(P, flipped).min_dihedral_deg > before + 10);
  }

  const auto r = mesh::split_slivers(P, tets, region, kept, 20.0, 1.5, 3, false);  // the new-vertex refill alone
  const double after = mesh::tet_stats(P, tets).min_dihedral_deg;
  MESSAGE("min dihedral " << before << " -> " << after << " deg, " << tets.size() << " tets, new vertex at "
                          << P.back().x << " " << P.back().y << " " << P.back().z);
  CHECK(r.inserted == 1);
  CHECK(r.failed == 0);
  REQUIRE(P.size() == 6);
  CHECK(before < 12);
  CHECK(after > before + 10);
  CHECK(tets.size() == 6);  // the cone over the cavity's six boundary faces
  REQUIRE(region.size() == tets.size());
  double new_volume = 0;
  for (const auto& t : tets) {
    CHECK((orient(P, t) > 0) == positive);
    new_volume += std::fabs(orient(P, t));
  }
  CHECK(new_volume == doctest::Approx(volume).epsilon(1e-9));
  for (int g : region) CHECK(g == 7);
  // The kept triangles are still faces of the mesh, each of exactly one tet.
  for (auto f : kept) {
    std::sort(f.begin(), f.end());
    int owners = 0;
    for (const auto& t : tets) {
      int shared = 0;
      for (uint32_t v : t) shared += int(std::find(f.begin(), f.end(), v) != f.end());
      owners += shared == 3;
    }
    CHECK(owners == 1);
  }
}

TEST_CASE("split_slivers: a sliver among four surface vertices goes by edge removal, unless a kept face is on the edge") {
  // The classic sliver: a square's corners, one diagonal (a, c) lifted and the other (b, d) lowered, so its angles at
  // both diagonals are near 180 degrees. Two tets join the top faces to an apex e, so three tets surround a-c; all
  // five vertices are kept surface vertices. Removing edge a-c leaves the two halves of the pyramid bdea, bdec.
  const double eps = 0.05;
  std::vector<glm::dvec3> P = {{0, 0, eps}, {1, 0, -eps}, {1, 1, eps}, {0, 1, -eps}, {0.5, 0.5, 1.0}};
  const uint32_t a = 0, b = 1, c = 2, d = 3, e = 4;
  std::vector<std::array<uint32_t, 4>> tets = {{a, b, c, d}, {a, c, d, e}, {a, c, e, b}};
  const auto [positive, volume] = orient_like_first(P, tets);
  const double before = mesh::tet_stats(P, tets).min_dihedral_deg;
  REQUIRE(before < 12);
  // The outer faces may be kept (interface triangles): only the faces on the removed edge may not.
  const std::vector<std::array<uint32_t, 3>> outer = {{a, b, d}, {b, c, d}, {a, d, e}, {c, d, e}, {a, b, e}, {b, c, e}};
  auto T = tets;
  std::vector<int> region = {2, 2, 2};
  const auto before_points = P;
  const auto r = mesh::split_slivers(P, T, region, outer, 12.0);
  const double after = mesh::tet_stats(P, T).min_dihedral_deg;
  MESSAGE("min dihedral " << before << " -> " << after << " deg");
  CHECK(r.flips == 1);
  CHECK(r.inserted == 0);
  CHECK(r.failed == 0);
  CHECK(P == before_points);
  REQUIRE(T.size() == 2);
  CHECK(region == std::vector<int>{2, 2});
  CHECK(after > 30);
  double new_volume = 0;
  for (const auto& t : T) {
    CHECK((orient(P, t) > 0) == positive);
    new_volume += std::fabs(orient(P, t));
    CHECK(std::count(t.begin(), t.end(), a) + std::count(t.begin(), t.end(), c) == 1);  // edge a-c is gone
  }
  CHECK(new_volume == doctest::Approx(volume).epsilon(1e-12));
  // A kept face on edge a-c (here ace) forbids removing it; the other long edge b-d has only the sliver around it.
  auto T2 = tets;
  std::vector<int> region2 = {2, 2, 2};
  auto with_ace = outer;
  with_ace.push_back({a, c, e});
  const auto r2 = mesh::split_slivers(P, T2, region2, with_ace, 12.0, 1.5, 3, true);
  CHECK(r2.flips == 0);
  // Nor across regions.
  auto T3 = tets;
  std::vector<int> region3 = {2, 2, 5};
  CHECK(mesh::split_slivers(P, T3, region3, outer, 12.0).flips == 0);
}

TEST_CASE("split_slivers: a sliver walled in by kept faces is reported and left as it is") {
  // One flat tet whose four faces are all kept (a sliver-shaped component between interfaces): no neighbour can join
  // the cavity, and a vertex inside it only makes flatter tets.
  std::vector<glm::dvec3> P = {{0, 0, 0}, {2, 0, 0}, {1, 1.7, 0.1}, {1, 0.6, 0.12}};
  std::vector<std::array<uint32_t, 4>> tets = {{0, 1, 2, 3}};
  std::vector<int> region = {3};
  const std::vector<std::array<uint32_t, 3>> kept = {{0, 1, 2}, {0, 1, 3}, {0, 2, 3}, {1, 2, 3}};
  const auto before_points = P;
  const auto before_tets = tets;
  const double before = mesh::tet_stats(P, tets).min_dihedral_deg;
  REQUIRE(before < 12);
  const auto r = mesh::split_slivers(P, tets, region, kept, 12.0);
  CHECK(r.inserted == 0);
  CHECK(r.failed == 1);
  CHECK(P == before_points);
  CHECK(tets == before_tets);
  CHECK(region == std::vector<int>{3});
}

TEST_CASE("constrained_quality: a cube meshes; intersecting facets are an error, not a crash") {
  // The unit cube's surface, 12 triangles, outward.
  std::vector<glm::dvec3> points;
  for (int c = 0; c < 8; ++c) points.push_back(glm::dvec3(c & 1, (c >> 1) & 1, c >> 2) * 4.0);
  std::vector<std::array<uint32_t, 3>> cube = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                                               {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  const std::vector<mesh::Region> regions = {{glm::dvec3(2.0), 1}};
  const auto good = mesh::constrained_quality(points, cube, {}, regions, {});
  CHECK(good.tets.size() >= 5);
  double volume = 0;
  for (const auto& t : good.tets)
    volume += std::fabs(glm::dot(good.points[t[1]] - good.points[t[0]],
                                 glm::cross(good.points[t[2]] - good.points[t[0]], good.points[t[3]] - good.points[t[0]]))) / 6.0;
  CHECK(volume == doctest::Approx(64.0));
  // An open cube (one face missing): its region leaks outside and TetGen drops the vertices left outside every
  // region, so the triangles would index other points. That must be an error.
  {
    const std::vector<std::array<uint32_t, 3>> open(cube.begin() + 2, cube.end());
    bool thrown = false;
    try {
      mesh::constrained_quality(points, open, {}, regions, {});
    } catch (const std::runtime_error& e) {
      thrown = true;
      MESSAGE("open cube: " << std::string(e.what()));
      CHECK(std::string(e.what()).find("not closed") != std::string::npos);
    }
    CHECK(thrown);
  }
  // A triangle that pierces two faces of the cube: TetGen cannot recover it (and the Debian build of TetGen 1.5
  // crashes when it gives up); the call must throw instead.
  auto pierced = cube;
  points.push_back({-1.0, 2.0, 1.0});
  points.push_back({5.0, 2.0, 1.0});
  points.push_back({2.0, 2.0, 3.0});
  pierced.push_back({8, 9, 10});
  bool thrown = false;
  try {
    mesh::constrained_quality(points, pierced, {}, regions, {});
  } catch (const std::runtime_error& e) {
    thrown = true;
    MESSAGE("pierced cube: " << std::string(e.what()));
    CHECK(std::string(e.what()).find("TetGen") != std::string::npos);
  }
  CHECK(thrown);
}

TEST_CASE("constrained_quality: points no triangle uses, one of them on a corner, stay out of the mesh and its numbering") {
  // Particles left out near junctions, and merged duplicates, stay in the vertex list. TetGen drops a point that
  // coincides with another, which once shifted every later index (and was then reported as a leaking region).
  std::vector<glm::dvec3> points = {glm::dvec3(4, 4, 4), glm::dvec3(2, 2, 2)};  // unused: on corner 7, and inside
  for (int c = 0; c < 8; ++c) points.push_back(glm::dvec3(c & 1, (c >> 1) & 1, c >> 2) * 4.0);
  std::vector<std::array<uint32_t, 3>> cube = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                                               {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (auto& t : cube)
    for (auto& v : t) v += 2;
  const auto V = mesh::constrained_quality(points, cube, {}, {{glm::dvec3(1.0), 1}}, {});
  REQUIRE(V.points.size() >= points.size());
  CHECK(std::equal(points.begin(), points.end(), V.points.begin()));
  double volume = 0;
  bool unused_in_tet = false;
  for (const auto& t : V.tets) {
    volume += std::fabs(glm::dot(V.points[t[1]] - V.points[t[0]],
                                 glm::cross(V.points[t[2]] - V.points[t[0]], V.points[t[3]] - V.points[t[0]]))) / 6.0;
    for (uint32_t v : t) unused_in_tet = unused_in_tet || v < 2;
  }
  CHECK(volume == doctest::Approx(64.0));
  CHECK(!unused_in_tet);
  for (const auto& f : V.faces)  // the kept boundary faces lie on the cube's surface
    for (uint32_t v : f) {
      REQUIRE(v < V.points.size());
      const glm::dvec3 p = V.points[v];
      CHECK((p.x == 0 || p.x == 4 || p.y == 0 || p.y == 4 || p.z == 0 || p.z == 4));
    }
}

TEST_CASE("delaunay: coincident points are meshed once and every index still names its own point") {
  // TetGen drops a coincident point from its output, which once shifted every later index by one. The tets of a
  // unit cube's corners and inner points must fill exactly its volume, with the duplicate in no tet.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.1, 0.9);
  std::vector<glm::dvec3> points;
  for (int c = 0; c < 8; ++c) points.push_back({double(c & 1), double(c >> 1 & 1), double(c >> 2)});
  for (int i = 0; i < 40; ++i) points.push_back({u(rng), u(rng), u(rng)});
  points.insert(points.begin() + 20, points[12]);  // point 20 duplicates point 12 (now 13)
  const auto T = mesh::delaunay(points);
  double volume = 0;
  bool duplicate_used = false;
  for (const auto& t : T.tets) {
    volume += std::fabs(glm::dot(points[t[1]] - points[t[0]], glm::cross(points[t[2]] - points[t[0]], points[t[3]] - points[t[0]]))) / 6;
    for (uint32_t v : t) duplicate_used = duplicate_used || v == 20;
  }
  CHECK(volume == doctest::Approx(1.0).epsilon(1e-12));
  CHECK(!duplicate_used);
  CHECK(T.points == points);
}

namespace {

// Box faces as two triangles each, over a shared vertex list (a vertex at the same place is one vertex).
struct BoxSurfaces {
  std::vector<glm::dvec3> points;
  std::vector<std::array<uint32_t, 3>> triangles;
  std::vector<std::array<uint16_t, 2>> pair;
  std::map<std::array<double, 3>, uint32_t> at;
  uint32_t vertex(const glm::dvec3& p) {
    const auto [it, added] = at.emplace(std::array<double, 3>{p.x, p.y, p.z}, uint32_t(points.size()));
    if (added) points.push_back(p);
    return it->second;
  }
  // The face of box [lo, hi] on `axis` at side `high`, between materials a < b, as unit squares (integer corners).
  void face(glm::dvec3 lo, glm::dvec3 hi, int axis, bool high, uint16_t a, uint16_t b) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    auto corner = [&](double cu, double cv) {
      glm::dvec3 p;
      p[axis] = high ? hi[axis] : lo[axis];
      p[u] = cu;
      p[v] = cv;
      return vertex(p);
    };
    for (double cu = lo[u]; cu < hi[u]; ++cu)
      for (double cv = lo[v]; cv < hi[v]; ++cv) {
        const uint32_t p00 = corner(cu, cv), p10 = corner(cu + 1, cv), p11 = corner(cu + 1, cv + 1),
                       p01 = corner(cu, cv + 1);
        triangles.push_back({p00, p10, p11});
        triangles.push_back({p00, p11, p01});
        pair.push_back({a, b});
        pair.push_back({a, b});
      }
  }
};

}  // namespace

TEST_CASE("mesh_materials: three boxes, one holding two that touch, meshed per material, conforming on every interface") {
  // Material 1 is the box [0,6]^3 with two boxes inside it: material 2 = [1,3]x[1,5]x[1,5] and material 3 =
  // [3,5]x[1,5]x[1,5], which share the face x = 3. Material 0 is the unmeshed outside.
  BoxSurfaces s;
  const glm::dvec3 o0(0.0), o1(6.0), a0(1.0), a1(3.0, 5.0, 5.0), b0(3.0, 1.0, 1.0), b1(5.0);
  for (int axis = 0; axis < 3; ++axis)
    for (bool high : {false, true}) {
      s.face(o0, o1, axis, high, 0, 1);
      if (!(axis == 0 && high)) s.face(a0, a1, axis, high, 1, 2);
      if (!(axis == 0 && !high)) s.face(b0, b1, axis, high, 1, 3);
    }
  s.face(a0, a1, 0, true, 2, 3);
  REQUIRE(s.points.size() == (343 - 125) + (125 - 27) + 9);  // the outer box's, the inner ones', the shared face's
  const std::vector<mesh::Region> seeds = {{glm::dvec3(0.5), 2}, {glm::dvec3(2.0, 3.0, 3.0), 3}, {glm::dvec3(4.0, 3.0, 3.0), 4}};
  const std::vector<uint16_t> labels = {0, 10, 20, 30};
  const mesh::QualityOptions options;
  const auto r = mesh::mesh_materials(s.points, s.triangles, s.pair, seeds, labels, options);
  const auto& T = r.tets;
  REQUIRE(T.region.size() == T.tets.size());
  CHECK(std::equal(s.points.begin(), s.points.end(), T.points.begin()));
  std::map<int, double> volume;
  std::map<std::array<uint32_t, 3>, std::multiset<int>> faces;  // sorted corners -> regions of the tets on it
  for (size_t i = 0; i < T.tets.size(); ++i) {
    const auto& t = T.tets[i];
    volume[T.region[i]] += std::fabs(glm::dot(T.points[t[1]] - T.points[t[0]],
                                              glm::cross(T.points[t[2]] - T.points[t[0]], T.points[t[3]] - T.points[t[0]]))) / 6.0;
    for (int c = 0; c < 4; ++c) {
      std::array<uint32_t, 3> f = {t[size_t((c + 1) % 4)], t[size_t((c + 2) % 4)], t[size_t((c + 3) % 4)]};
      std::sort(f.begin(), f.end());
      faces[f].insert(T.region[i]);
    }
  }
  MESSAGE(T.tets.size() << " tets, " << T.points.size() - s.points.size() << " points added; min dihedral "
                        << r.improvement.min_dihedral_before << " -> " << r.improvement.min_dihedral_after);
  CHECK(volume.size() == 3);  // regions 2, 3, 4 only: no tet outside, none unlabelled
  CHECK(volume[2] == doctest::Approx(216.0 - 64.0));
  CHECK(volume[3] == doctest::Approx(32.0));
  CHECK(volume[4] == doctest::Approx(32.0));
  // Every interface triangle is a face of one tet of each meshed material beside it: the meshes conform.
  for (size_t i = 0; i < s.triangles.size(); ++i) {
    auto f = s.triangles[i];
    std::sort(f.begin(), f.end());
    std::multiset<int> expect;
    for (uint16_t m : s.pair[i])
      if (m > 0) expect.insert(int(m) + 1);
    CHECK(faces[f] == expect);
  }
  CHECK(mesh::tet_stats(T.points, T.tets).min_dihedral_deg >= 10.0);
  CHECK(r.sliver_split.failed == 0);

  // One thread gives the same mesh: the runs are merged in material order.
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    const auto serial = mesh::mesh_materials(s.points, s.triangles, s.pair, seeds, labels, options);
    CHECK(serial.tets.points == T.points);
    CHECK(serial.tets.tets == T.tets);
    CHECK(serial.tets.region == T.region);
  }

  CHECK(r.one_run_because.empty());

  // Material 2's face at x = 1 missing: meshed alone it leaks into the outside, so all are meshed in one run, where
  // the leak only joins it to material 1 (the same space filled once).
  {
    std::vector<std::array<uint32_t, 3>> open;
    std::vector<std::array<uint16_t, 2>> open_pair;
    for (size_t i = 0; i < s.triangles.size(); ++i) {
      bool on_face = s.pair[i] == std::array<uint16_t, 2>{1, 2};
      for (uint32_t v : s.triangles[i]) on_face = on_face && s.points[v].x == 1.0;
      if (on_face) continue;
      open.push_back(s.triangles[i]);
      open_pair.push_back(s.pair[i]);
    }
    REQUIRE(open.size() == s.triangles.size() - 32);
    const auto one = mesh::mesh_materials(s.points, open, open_pair, seeds, labels, options);
    MESSAGE("open face: " << one.one_run_because);
    CHECK(one.one_run_because.find("volume mesh of material 20") != std::string::npos);
    double all = 0, b = 0;
    for (size_t i = 0; i < one.tets.tets.size(); ++i) {
      const auto& t = one.tets.tets[i];
      const auto& P = one.tets.points;
      const double v = std::fabs(glm::dot(P[t[1]] - P[t[0]], glm::cross(P[t[2]] - P[t[0]], P[t[3]] - P[t[0]]))) / 6.0;
      all += v;
      if (one.tets.region[i] == 4) b += v;
    }
    CHECK(all == doctest::Approx(216.0));
    CHECK(b == doctest::Approx(32.0));
  }

  // A triangle piercing the faces of materials 1 and 2: the error names a material, and nothing crashes.
  auto points = s.points;
  auto triangles = s.triangles;
  auto pair = s.pair;
  points.push_back({0.5, 2.0, 2.0});
  points.push_back({2.5, 2.0, 2.0});
  points.push_back({1.5, 2.0, 4.0});
  triangles.push_back({uint32_t(points.size() - 3), uint32_t(points.size() - 2), uint32_t(points.size() - 1)});
  pair.push_back({1, 2});
  bool thrown = false;
  try {
    mesh::mesh_materials(points, triangles, pair, seeds, labels, options);
  } catch (const std::runtime_error& e) {
    thrown = true;
    MESSAGE("pierced: " << std::string(e.what()));
    CHECK(std::string(e.what()).find("volume mesh of material") != std::string::npos);
  }
  CHECK(thrown);
}

namespace {

// improve_tets written out plainly: its rounds one vertex at a time, every angle recomputed from scratch, each round's
// movers found by looking up every waiting vertex's tets' corners in the waiting list. The library's version moves a round's
// vertices in parallel, keeps the angles as cosines and current, and tests fewer tets; the moves must be the same.
mesh::TetImproveReport improve_tets_plain(std::vector<glm::dvec3>& P, const std::vector<std::array<uint32_t, 4>>& tets,
                                          size_t fixed, double target_deg, double max_radius_edge, int passes) {
  mesh::TetImproveReport report;
  const double target = target_deg * M_PI / 180;
  auto signed_volume = [&](const std::array<uint32_t, 4>& t) {
    return glm::dot(P[t[1]] - P[t[0]], glm::cross(P[t[2]] - P[t[0]], P[t[3]] - P[t[0]]));
  };
  auto min_angle = [&](const std::array<uint32_t, 4>& t) {
    const auto a = mesh::dihedral_angles(P[t[0]], P[t[1]], P[t[2]], P[t[3]]);
    return *std::min_element(a.begin(), a.end());
  };
  auto worst = [&] {
    double w = M_PI;
    for (const auto& t : tets) w = std::min(w, min_angle(t));
    return w * 180 / M_PI;
  };
  std::vector<std::vector<uint32_t>> around(P.size());
  std::vector<int8_t> sign(tets.size());
  for (uint32_t t = 0; t < tets.size(); ++t) {
    for (uint32_t v : tets[t]) around[v].push_back(t);
    sign[t] = signed_volume(tets[t]) > 0 ? 1 : -1;
  }
  report.min_dihedral_before = worst();
  auto quality_at = [&](uint32_t v, double limit) {
    double q = M_PI;
    for (uint32_t t : around[v]) {
      const auto& k = tets[t];
      if (signed_volume(k) * sign[t] <= 0 || mesh::radius_edge_ratio(P[k[0]], P[k[1]], P[k[2]], P[k[3]]) > limit)
        return -1.0;
      q = std::min(q, min_angle(k));
    }
    return q;
  };
  auto to_mend = [&](uint32_t t) { return !(min_angle(tets[t]) >= target); };  // (a NaN angle too)
  auto move = [&](uint32_t v, int pass, int visit) {
    const glm::dvec3 start = P[v];
    double ratio = 0;
    for (uint32_t u : around[v])
      ratio = std::max(ratio, mesh::radius_edge_ratio(P[tets[u][0]], P[tets[u][1]], P[tets[u][2]], P[tets[u][3]]));
    const double limit = std::max(max_radius_edge, ratio);
    double best = quality_at(v, limit);
    glm::dvec3 best_at = start, centroid(0.0);
    double edge = 0;
    size_t count = 0;
    for (uint32_t u : around[v])
      for (uint32_t w : tets[u])
        if (w != v) {
          centroid += P[w];
          edge += glm::length(P[w] - start);
          ++count;
        }
    if (count == 0) return false;
    centroid /= double(count);
    edge /= double(count);
    auto consider = [&](const glm::dvec3& at) {
      P[v] = at;
      const double q = quality_at(v, limit);
      if (q > best) best = q, best_at = at;
    };
    consider(centroid);
    uint64_t draw = uint64_t(pass) << 56 ^ uint64_t(visit) << 48 ^ uint64_t(v) << 16;
    for (double step = 0.2 * edge; step > 0.01 * edge; step *= 0.5)
      for (int k = 0; k < 8; ++k, draw += 3)
        consider(best_at + step *
                               glm::dvec3(mesh::hashed_normal(draw), mesh::hashed_normal(draw + 1),
                                          mesh::hashed_normal(draw + 2)) / std::sqrt(3.0));
    P[v] = best_at;
    return best_at != start;
  };
  for (int pass = 0; pass < passes; ++pass) {
    size_t moves = 0;
    std::vector<uint32_t> waiting;  // in rank order
    std::vector<int> visits(P.size(), 0);
    for (uint32_t t = 0; t < tets.size(); ++t)
      if (to_mend(t))
        for (uint32_t v : tets[t])
          if (v >= fixed && visits[v] == 0) waiting.push_back(v), visits[v] = 1;
    while (!waiting.empty()) {
      std::vector<int> place(P.size(), -1);
      for (size_t i = 0; i < waiting.size(); ++i) place[waiting[i]] = int(i);
      std::vector<uint8_t> chosen(waiting.size(), 1);
      for (size_t i = 0; i < waiting.size(); ++i)
        for (uint32_t u : around[waiting[i]])
          for (uint32_t w : tets[u])
            if (place[w] >= 0 && place[w] < int(i)) chosen[i] = 0;
      std::vector<uint32_t> next, moved;
      for (size_t i = 0; i < waiting.size(); ++i) {
        const uint32_t v = waiting[i];
        if (!chosen[i]) {
          next.push_back(v);
          continue;
        }
        bool any = false;
        for (uint32_t u : around[v]) any = any || to_mend(u);
        if (any && move(v, pass, visits[v])) moved.push_back(v);
      }
      for (uint32_t v : moved) {
        ++moves;
        for (uint32_t u : around[v])
          if (to_mend(u))
            for (uint32_t w : tets[u])
              if (w >= fixed && std::find(next.begin(), next.end(), w) == next.end() && visits[w] < 3)
                next.push_back(w), ++visits[w];
      }
      waiting = next;
    }
    report.moves += moves;
    if (moves == 0) break;
  }
  report.min_dihedral_after = worst();
  return report;
}

}  // namespace

TEST_CASE("improve_tets: the same moves as its rounds written out plainly, on any thread count") {
  // The Delaunay tets of jittered grid points: many slivers, and vertices in several of them (a move changes which
  // tets come later in the pass below the target).
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);
  std::vector<glm::dvec3> P;
  for (int z = 0; z < 9; ++z)
    for (int y = 0; y < 9; ++y)
      for (int x = 0; x < 9; ++x) P.push_back(glm::dvec3(x + jitter(rng), y + jitter(rng), z + jitter(rng)));
  const auto T = mesh::delaunay(P);
  const size_t fixed = 100;  // some vertices may not move, as the surface vertices in the volume mesh
  for (double target : {12.0, 25.0}) {
    auto plain = P;
    const auto expected = improve_tets_plain(plain, T.tets, fixed, target, 1.5, 4);
    REQUIRE(expected.moves > 20);
    for (int threads : {1, 4}) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
      auto moved = P;
      const auto r = mesh::improve_tets(moved, T.tets, fixed, target, 1.5, 4);
      CHECK(r.moves == expected.moves);
      CHECK(r.min_dihedral_before == expected.min_dihedral_before);
      CHECK(r.min_dihedral_after == expected.min_dihedral_after);
      CHECK(moved == plain);
    }
  }
}

TEST_CASE("dihedral_range, min_dihedral and tet_stats_by_group agree with the angles of each tet") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<glm::dvec3> P;
  for (int i = 0; i < 400; ++i) P.push_back(glm::dvec3(u(rng), u(rng), u(rng)));
  const auto T = mesh::delaunay(P);
  std::vector<uint16_t> group(T.tets.size());
  std::vector<std::vector<std::array<uint32_t, 4>>> by(3);
  for (size_t i = 0; i < T.tets.size(); ++i) {
    const auto& t = T.tets[i];
    const auto a = mesh::dihedral_angles(P[t[0]], P[t[1]], P[t[2]], P[t[3]]);
    const auto r = mesh::dihedral_range(P[t[0]], P[t[1]], P[t[2]], P[t[3]]);
    CHECK(r[0] == *std::min_element(a.begin(), a.end()));
    CHECK(r[1] == *std::max_element(a.begin(), a.end()));
    CHECK(mesh::min_dihedral(P[t[0]], P[t[1]], P[t[2]], P[t[3]]) == r[0]);
    group[i] = uint16_t(i % 2);  // group 2 stays empty
    by[group[i]].push_back(t);
  }
  const auto stats = mesh::tet_stats_by_group(P, T.tets, group, 3);
  REQUIRE(stats.size() == 3);
  for (size_t g = 0; g < 2; ++g) {
    // The plain definition: every angle and ratio of the group's tets.
    double lo = 180, hi = 0, re_max = 0, re_sum = 0;
    for (const auto& t : by[g]) {
      for (double a : mesh::dihedral_angles(P[t[0]], P[t[1]], P[t[2]], P[t[3]])) {
        lo = std::min(lo, a * 180 / M_PI);
        hi = std::max(hi, a * 180 / M_PI);
      }
      const double re = mesh::radius_edge_ratio(P[t[0]], P[t[1]], P[t[2]], P[t[3]]);
      re_max = std::max(re_max, re);
      re_sum += re;
    }
    CHECK(stats[g].tets == by[g].size());
    CHECK(stats[g].min_dihedral_deg == lo);
    CHECK(stats[g].max_dihedral_deg == hi);
    CHECK(stats[g].max_radius_edge == re_max);
    CHECK(stats[g].mean_radius_edge == doctest::Approx(re_sum / double(by[g].size())).epsilon(1e-12));
  }
  CHECK(stats[2].tets == 0);
  const auto all = mesh::combined(stats), whole = mesh::tet_stats(P, T.tets);
  CHECK(all.tets == T.tets.size());
  CHECK(all.min_dihedral_deg == whole.min_dihedral_deg);
  CHECK(all.max_dihedral_deg == whole.max_dihedral_deg);
  CHECK(all.max_radius_edge == whole.max_radius_edge);
  CHECK(all.mean_radius_edge == doctest::Approx(whole.mean_radius_edge).epsilon(1e-12));
}

TEST_CASE("tet_stats_by_group and combined name the worst tet: the first with the smallest angle, on any thread count") {
  // A Delaunay mesh's tets listed twelve times over (in more than two of the reduction's chunks of 16384): every smallest
  // angle is tied by eleven later copies, in other chunks, and the first copy must win each time.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<glm::dvec3> P;
  for (int i = 0; i < 500; ++i) P.push_back(glm::dvec3(u(rng), u(rng), u(rng)));
  const auto T = mesh::delaunay(P);
  std::vector<std::array<uint32_t, 4>> tets;
  for (int copy = 0; copy < 12; ++copy) tets.insert(tets.end(), T.tets.begin(), T.tets.end());
  REQUIRE(tets.size() > 2 * 16384);
  std::vector<uint16_t> group(tets.size());
  // Copy k in group 2 - k % 3: the first copy's tets in the last group, so that a group's worst tet ties the worst tet
  // of a group before it and combined must choose by the tets' order, not by the groups'.
  for (size_t i = 0; i < tets.size(); ++i) group[i] = uint16_t(2 - (i / T.tets.size()) % 3);
  // The plain definition, per group and over all.
  std::vector<size_t> worst(3, SIZE_MAX);
  std::vector<double> lo(3, 180);
  size_t worst_all = SIZE_MAX;
  double lo_all = 180;
  for (size_t i = 0; i < tets.size(); ++i) {
    const auto& t = tets[i];
    const double d = mesh::dihedral_range(P[t[0]], P[t[1]], P[t[2]], P[t[3]])[0] * 180 / M_PI;
    if (d < lo[group[i]]) {
      lo[group[i]] = d;
      worst[group[i]] = i;
    }
    if (d < lo_all) {
      lo_all = d;
      worst_all = i;
    }
  }
  for (int threads : {1, 2, 4}) {
    CAPTURE(threads);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
    const auto stats = mesh::tet_stats_by_group(P, tets, group, 4);  // group 3 stays empty
    for (size_t g = 0; g < 3; ++g) {
      CAPTURE(g);
      CHECK(stats[g].worst_tet == worst[g]);
      const auto& t = tets[worst[g]];
      CHECK(stats[g].worst_centroid == (P[t[0]] + P[t[1]] + P[t[2]] + P[t[3]]) / 4.0);
    }
    CHECK(stats[3].worst_tet == SIZE_MAX);
    const auto all = mesh::combined(stats);
    CHECK(all.min_dihedral_deg == lo_all);
    CHECK(all.worst_tet == worst_all);
    CHECK(all.worst_tet < T.tets.size());  // in the first copy
    CHECK(mesh::tet_stats(P, tets).worst_tet == worst_all);
  }
  CHECK(mesh::tet_stats(P, {}).worst_tet == SIZE_MAX);
}

TEST_CASE("min_dihedral_cosine_unless_above and radius_edge_above give the exact answers, bounds at a hair's breadth") {
  // Random tets, flattened ones (the fourth corner near the plane of the other three, down to on it), needles and a
  // repeated corner: the cheap tests must settle only what the exact values settle the same way.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  auto point = [&] { return glm::dvec3(u(rng), u(rng), u(rng)); };
  std::vector<std::array<glm::dvec3, 4>> tets;
  for (int i = 0; i < 300; ++i) tets.push_back({point(), point(), point(), point()});
  for (double h : {1e-1, 1e-3, 1e-6, 1e-9, 1e-13, 0.0})
    for (int i = 0; i < 20; ++i) {
      const glm::dvec3 a = point(), b = point(), c = point();
      const glm::dvec3 n = glm::normalize(glm::cross(b - a, c - a));
      tets.push_back({a, b, c, (a + b + c) / 3.0 + 0.3 * point() * glm::dvec3(1, 1, 0) + h * n});
    }
  for (int i = 0; i < 20; ++i) {
    const glm::dvec3 a = point(), d = point();
    tets.push_back({a, a + 1e-7 * point(), a + 1e-7 * point(), d});  // a needle
    tets.push_back({a, a, point(), d});                                 // a repeated corner
  }
  // Far outside any mesh's scale (a review found each of these wrong before the squares were kept in range): the
  // squared normals overflow near 3e38, turn subnormal near 1e-40 and underflow near 1e-81; near 1e154 the exact
  // value is NaN.
  for (double scale : {1e-81, 1e-40, 1e38, 3e38, 1e154})
    for (int i = 0; i < 5; ++i) {
      std::array<glm::dvec3, 4> t = i == 0 ? std::array<glm::dvec3, 4>{glm::dvec3(0), glm::dvec3(1, 0, 0),
                                                                       glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1)}
                                           : std::array<glm::dvec3, 4>{point(), point(), point(), point()};
      for (auto& p : t) p *= scale;
      tets.push_back(t);
    }
  tets.push_back({glm::dvec3(0), glm::dvec3(1e-10, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0.3, 0.4, 1e-150)});
  size_t settled_above = 0, cases = 0;
  for (const auto& t : tets) {
    const double c = mesh::min_dihedral_cosine(t[0], t[1], t[2], t[3]);
    if (!std::isnan(c)) CHECK(mesh::min_dihedral(t[0], t[1], t[2], t[3]) == mesh::dihedral_from_cosine(c));
    for (double bound : {c, std::nextafter(c, 2.0), std::nextafter(c, -2.0), c + 1e-12, c - 1e-12, c - 1e-6, c + 1e-6,
                         c - 0.1, c + 0.1, -1.0, 1.0, -2.0, 0.0}) {
      const double r = mesh::min_dihedral_cosine_unless_above(t[0], t[1], t[2], t[3], bound);
      ++cases;
      if (std::isnan(c)) {
        CHECK(std::isnan(r));
      } else if (r == HUGE_VAL) {
        CHECK(c > bound);
        ++settled_above;
      } else {
        CHECK(r == c);
      }
    }
    const double ratio = mesh::radius_edge_ratio(t[0], t[1], t[2], t[3]);
    for (double limit : {ratio, std::nextafter(ratio, HUGE_VAL), std::nextafter(ratio, 0.0), ratio * (1 + 1e-12),
                         ratio * (1 - 1e-12), ratio * 1.01, ratio * 0.99, 0.0, 1.5, HUGE_VAL, -1.0, 1e155}) {
      const bool above = mesh::radius_edge_above(t[0], t[1], t[2], t[3], limit);
      CHECK(above == (ratio > limit));
    }
  }
  // The cheap test did settle many cases (else this compares the exact values with themselves).
  CHECK(settled_above > cases / 4);
}

TEST_CASE("seam_passes: slivers in a large mesh are mended within their part, and every tet away from them stays") {
  // An 8^3 cube lattice, each cube in six tets around its main diagonal (a conforming mesh), boundary points first
  // (fixed), the boundary faces kept. Two interior points far apart are pushed along the diagonal until some of their
  // tets are slivers (still positive).
  const int n = 8;
  auto id = [&](int x, int y, int z) { return (z * (n + 1) + y) * (n + 1) + x; };
  std::vector<int> number((n + 1) * (n + 1) * (n + 1), -1);
  std::vector<glm::dvec3> P;
  for (int pass = 0; pass < 2; ++pass)
    for (int z = 0; z <= n; ++z)
      for (int y = 0; y <= n; ++y)
        for (int x = 0; x <= n; ++x) {
          const bool boundary = x == 0 || y == 0 || z == 0 || x == n || y == n || z == n;
          if (boundary != (pass == 0)) continue;
          number[size_t(id(x, y, z))] = int(P.size());
          P.push_back(glm::dvec3(x, y, z));
        }
  const size_t fixed = size_t(std::count_if(P.begin(), P.end(), [&](const glm::dvec3& p) {
    return p.x == 0 || p.y == 0 || p.z == 0 || p.x == n || p.y == n || p.z == n;
  }));
  mesh::Tets T;
  const int perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        for (const auto& p : perm) {
          std::array<int, 3> c = {x, y, z};
          std::array<uint32_t, 4> t;
          t[0] = uint32_t(number[size_t(id(c[0], c[1], c[2]))]);
          for (int k = 0; k < 3; ++k) {
            ++c[size_t(p[k])];
            t[size_t(k) + 1] = uint32_t(number[size_t(id(c[0], c[1], c[2]))]);
          }
          T.tets.push_back(t);
          T.region.push_back(1);
        }
  T.points = P;
  for (auto& t : T.tets)
    if (orient(T.points, t) < 0) std::swap(t[0], t[1]);
  const double volume = orient_like_first(T.points, T.tets).second;
  std::map<std::array<uint32_t, 3>, int> uses;
  for (const auto& t : T.tets)
    for (int c = 0; c < 4; ++c) {
      auto f = mesh::face_opposite(t, c);
      std::sort(f.begin(), f.end());
      ++uses[f];
    }
  std::vector<std::array<uint32_t, 3>> kept;
  for (const auto& [f, k] : uses)
    if (k == 1) kept.push_back(f);
  REQUIRE(kept.size() == size_t(6 * 2 * n * n));
  const glm::dvec3 pushed[2] = {glm::dvec3(2, 2, 2), glm::dvec3(6, 5, 6)};
  for (const auto& p : pushed) T.points[size_t(number[size_t(id(int(p.x), int(p.y), int(p.z)))])] += glm::dvec3(0.85, 0, 0);
  for (const auto& t : T.tets) REQUIRE(orient(T.points, t) > 0);
  mesh::QualityOptions options;
  const size_t slivers = mesh::count_below_dihedral(T.points, T.tets, options.min_dihedral);
  REQUIRE(slivers > 0);
  // The tets with no point within 3 of a pushed one, by their corners' coordinates.
  auto corners = [](const std::vector<glm::dvec3>& Q, const std::array<uint32_t, 4>& t) {
    std::array<std::array<double, 3>, 4> c;
    for (int k = 0; k < 4; ++k) c[size_t(k)] = {Q[t[size_t(k)]].x, Q[t[size_t(k)]].y, Q[t[size_t(k)]].z};
    std::sort(c.begin(), c.end());
    return c;
  };
  std::vector<std::array<std::array<double, 3>, 4>> away;
  for (const auto& t : T.tets) {
    double d = 1e9;
    for (uint32_t v : t)
      for (const auto& p : pushed) d = std::min(d, glm::length(T.points[v] - p));
    if (d > 3.5) away.push_back(corners(T.points, t));
  }
  REQUIRE(away.size() > T.tets.size() / 3);
  const auto before = T;
  mesh::TetImproveReport improvement;
  mesh::SliverSplitReport split;
  REQUIRE(mesh::seam_passes(T, fixed, kept, options, improvement, split));
  MESSAGE(slivers << " slivers; after the passes " << split.failed << " under the bound, min dihedral "
                  << improvement.min_dihedral_after << ", " << T.tets.size() << " tets (" << before.tets.size()
                  << " before), " << improvement.moves << " moves");
  CHECK(split.failed == mesh::count_below_dihedral(T.points, T.tets, options.min_dihedral));
  CHECK(split.failed == 0);
  CHECK(improvement.min_dihedral_after == doctest::Approx(mesh::tet_stats(T.points, T.tets).min_dihedral_deg));
  CHECK(std::equal(before.points.begin(), before.points.begin() + std::ptrdiff_t(fixed), T.points.begin()));
  REQUIRE(T.region.size() == T.tets.size());
  CHECK(std::all_of(T.region.begin(), T.region.end(), [](int r) { return r == 1; }));
  // Every tet positive, the same volume, conforming with the same boundary, every point used.
  double after = 0;
  std::map<std::array<uint32_t, 3>, int> now;
  std::vector<uint8_t> used(T.points.size(), 0);
  for (const auto& t : T.tets) {
    CHECK(orient(T.points, t) > 0);
    after += orient(T.points, t);
    for (int c = 0; c < 4; ++c) {
      auto f = mesh::face_opposite(t, c);
      std::sort(f.begin(), f.end());
      ++now[f];
    }
    for (uint32_t v : t) used[v] = 1;
  }
  CHECK(after == doctest::Approx(volume).epsilon(1e-12));
  std::vector<std::array<uint32_t, 3>> boundary;
  size_t odd = 0;
  for (const auto& [f, k] : now) {
    if (k == 1) boundary.push_back(f);
    odd += k > 2;
  }
  CHECK(odd == 0);
  CHECK(boundary == kept);
  CHECK(std::count(used.begin(), used.end(), uint8_t(0)) == 0);
  // Away from the slivers nothing changed.
  std::set<std::array<std::array<double, 3>, 4>> have;
  for (const auto& t : T.tets) have.insert(corners(T.points, t));
  size_t missing = 0;
  for (const auto& c : away) missing += have.count(c) == 0;
  CHECK(missing == 0);
  // Nothing under the bound: nothing to do, T untouched.
  const auto settled = T;
  CHECK_FALSE(mesh::seam_passes(T, fixed, kept, options, improvement, split));
  CHECK(T.points == settled.points);
  CHECK(T.tets == settled.tets);
}
