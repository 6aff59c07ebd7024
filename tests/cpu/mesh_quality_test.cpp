// Triple-curve edges of interface meshes (mesh::triple_curve_edges) and the analytic curve distance
// (io::distance_to_triple_curve): the measures behind the junction error of the tests and benchmarks; the crossing
// test; the grouped checks and sums of the quality report.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>

#include <tbb/global_control.h>

#include "io/synth_volumes.h"
#include "mesh/quality.h"
#include "mesh/volume_mesh.h"

using namespace cpmesh;

TEST_CASE("triple_curve_edges: the edge three interfaces share, and no other") {
  // Edge 0-1 is shared by three triangles of pairs (1,2), (2,3), (1,3): a triple-curve edge of materials 1, 2, 3.
  // Edge 0-2 is shared by two pairs only; edge 1-5 by three pairs spanning four materials (not one curve).
  const std::vector<std::array<uint32_t, 3>> T = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}, {0, 2, 6}, {1, 5, 2}, {5, 1, 6}, {1, 5, 7}};
  const std::vector<std::array<uint16_t, 2>> P = {{1, 2}, {3, 2}, {1, 3}, {2, 3}, {1, 2}, {3, 4}, {2, 4}};
  const auto edges = mesh::triple_curve_edges(T, P);
  REQUIRE(edges.size() == 1);
  CHECK(edges[0].a == 0);
  CHECK(edges[0].b == 1);
  CHECK(edges[0].materials == std::array<uint16_t, 3>{1, 2, 3});
}

TEST_CASE("distance_to_triple_curve: wedge ball curves, and none for other material sets") {
  io::SynthOptions o;
  o.shape = io::SynthShape::wedge_ball;
  o.size = 64;
  const auto s = io::make_synth_volume(o);
  // The first quadruple point (north pole) lies on the (0, l, r) curves and on the axis curve (1, 2, 3).
  const auto& north = s.junctions.quadruple_points[0].position;
  CHECK(io::distance_to_triple_curve(s.junctions, {1, 2, 3}, north) < 1e-9);
  CHECK(io::distance_to_triple_curve(s.junctions, {0, 1, 2}, north) < 1e-9);
  // One voxel off the pole along x: at most 1 from each curve through it.
  const std::array<double, 3> off = {north[0] + 1, north[1], north[2]};
  const double d = io::distance_to_triple_curve(s.junctions, {1, 2, 3}, off);
  CHECK(d == doctest::Approx(1.0).epsilon(1e-9));  // the axis curve is parallel to z
  CHECK(std::isinf(io::distance_to_triple_curve(s.junctions, {0, 1, 4}, north)));
}

TEST_CASE("crossing_triangles: triangles through each other, and shared or touching ones that are not crossings") {
  const std::vector<glm::dvec3> V = {
      {0, 0, 0},   {4, 0, 0},   {0, 4, 0},  {1, 1, -1}, {1, 1, 1},     {2, 0.5, 1},  // 0-5: A, and B piercing it
      {10, 0, 0},  {14, 0, 0},  {10, 4, 0}, {8, 0, 1},  {10, -2, 1},   {13, 3, 1},   // 6-11
      {20, 0, 0},  {24, 0, 0},  {20, 4, 0}, {21, 1, -1}, {22.5, 1.5, 1},             // 12-16
      {30, 0, 0},  {34, 0, 0},  {30, 4, 0}, {30, 0, 0}, {28, 0, 1},    {30, -2, 1},  // 17-22
  };
  const std::vector<std::array<uint32_t, 3>> T = {
      {0, 1, 2},     // 0
      {3, 4, 5},     // 1: its edge 3-4 passes through triangle 0 at (1, 1, 0)
      {6, 7, 8},     // 2
      {6, 9, 10},    // 3: shares vertex 6 with triangle 2 and bends away from it
      {7, 8, 11},    // 4: shares edge 7-8 with triangle 2 (left to the flip checks)
      {12, 13, 14},  // 5
      {14, 15, 16},  // 6: shares vertex 14 with triangle 5; its opposite edge 15-16 passes through triangle 5
      {17, 18, 19},  // 7
      {20, 21, 22},  // 8: vertex 20 sits on triangle 7's corner 17 without being it: touching, not crossing
  };
  CHECK(mesh::crossing_triangles(V, T) == std::vector<std::array<uint32_t, 2>>{{0, 1}, {5, 6}});
  // Only pairs with a flagged triangle are tested.
  std::vector<uint8_t> only(T.size(), 0);
  only[6] = 1;
  CHECK(mesh::crossing_triangles(V, T, &only) == std::vector<std::array<uint32_t, 2>>{{5, 6}});
  only = {0, 0, 1, 1, 1, 0, 0, 1, 1};
  CHECK(mesh::crossing_triangles(V, T, &only).empty());
  // Most triangles through a non-finite vertex (their median edge is not a number): the finite pair is still found.
  std::vector<glm::dvec3> W = V;
  W.push_back(glm::dvec3(std::nan(""), 0, 0));
  W.push_back(glm::dvec3(std::numeric_limits<double>::infinity(), 0, 0));
  std::vector<std::array<uint32_t, 3>> U = {T[0], T[1]};
  for (uint32_t k = 0; k < 6; ++k) U.push_back({23 + (k & 1), k + 6, k + 7});
  CHECK(mesh::crossing_triangles(W, U) == std::vector<std::array<uint32_t, 2>>{{0, 1}});
}

TEST_CASE("crossing_triangles: triangles whose boxes do not meet never cross, whatever the rounding") {
  // s's largest x lies below t's smallest x (by 1e-16), but the boxes rounded to float meet, and the plain
  // floating-point crossing test says these two cross: the exact boxes must keep the pair out (a review found it).
  const std::vector<glm::dvec3> V = {{0.4438700941828696, 0.12005864862559806, 0.3533600268722884},
                                     {0.4438700941828696, 0.26852209728828547, 0.34555410487201826},
                                     {1.0266755132681227, 0.88036479385482891, 0.4394456971041521},
                                     {-0.59117667019893883, -0.18923964791685896, 0.12230441839452721},
                                     {0.44387009418286938, 0.1789010493665226, 0.35026620684702492},
                                     {-0.39784040919553332, 0.66474699674961824, 0.37153133277577371}};
  REQUIRE(V[4].x < V[0].x);
  CHECK(mesh::crossing_triangles(V, {{0, 1, 2}, {3, 4, 5}}).empty());
}

TEST_CASE("crossing_triangles: the grid finds every crossing pair that testing all pairs finds, dense and sparse") {
  // Random small triangles in a cluster 7 units wide, where the grid's cells (twice the median edge) are a few
  // units wide and triangles span several; then with a second cluster 1000 units away, a bounding box so sparse that
  // the grid widens its cells. The answer must be the all-pairs one (each pair tested on its own), with and without
  // flags.
  for (int clusters = 1; clusters <= 2; ++clusters) {
    CAPTURE(clusters);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::vector<glm::dvec3> V;
    std::vector<std::array<uint32_t, 3>> T;
    for (int cluster = 0; cluster < clusters; ++cluster)
      for (int t = 0; t < 250; ++t) {
        const glm::dvec3 centre = glm::dvec3(cluster * 1000.0) + 7.0 * glm::dvec3(unit(rng), unit(rng), unit(rng));
        const double size = t % 25 == 0 ? 6.0 : 1.5;
        const auto base = uint32_t(V.size());
        for (int k = 0; k < 3; ++k)
          V.push_back(centre + size * glm::dvec3(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5));
        T.push_back({base, base + 1, base + 2});
      }
    // Some shared vertices too: triangles that share one cross only through the edge opposite it.
    for (int t = 0; t < 40; ++t) {
      const auto a = uint32_t(rng() % V.size());
      const glm::dvec3 centre = V[a];
      const auto base = uint32_t(V.size());
      for (int k = 0; k < 2; ++k) V.push_back(centre + 2.0 * glm::dvec3(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5));
      T.push_back({a, base, base + 1});
    }
    std::vector<uint8_t> only(T.size());
    for (auto& f : only) f = uint8_t(rng() % 3 == 0);
    std::vector<std::array<uint32_t, 2>> all, flagged;
    for (uint32_t t = 0; t < T.size(); ++t)
      for (uint32_t u = t + 1; u < T.size(); ++u)
        if (!mesh::crossing_triangles(V, {T[t], T[u]}).empty()) {
          all.push_back({t, u});
          if (only[t] || only[u]) flagged.push_back({t, u});
        }
    REQUIRE(all.size() > 50);  // dense enough to test something
    CHECK(mesh::crossing_triangles(V, T) == all);
    CHECK(mesh::crossing_triangles(V, T, &only) == flagged);
  }
}

TEST_CASE("check_edges and triangle_sums_by_group: each interface's and material's checks and sums from one pass") {
  // A soup of random triangles over few vertices, in random interfaces of 5 materials: edges used once, twice and
  // more often, within one interface and across several; enough triangles for several of the sums' chunks.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<glm::dvec3> V(600);
  for (auto& p : V) p = {u(rng), u(rng), u(rng)};
  std::vector<uint8_t> on_curve(V.size());
  for (auto& c : on_curve) c = uint8_t(rng() % 3 == 0);
  const std::vector<std::array<uint16_t, 2>> pairs = {{0, 1}, {0, 2}, {1, 2}, {1, 4}, {2, 3}, {3, 4}};
  std::vector<std::array<uint32_t, 3>> T;
  std::vector<uint32_t> group;
  while (T.size() < 100000) {
    const uint32_t a = rng() % 600, b = rng() % 600, c = rng() % 600;
    if (a == b || b == c || a == c) continue;
    T.push_back({a, b, c});
    group.push_back(uint32_t(rng() % pairs.size()));
  }
  const auto checks = mesh::check_edges(T, group, pairs, 5, on_curve);
  std::vector<mesh::TriangleSums> sums;
  {
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 3);
    sums = mesh::triangle_sums_by_group(V, T, group, pairs.size());
  }
  const auto one_thread = [&] {
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 1);
    return mesh::triangle_sums_by_group(V, T, group, pairs.size());
  }();
  size_t nonmanifold = 0, open = 0;
  for (size_t g = 0; g < pairs.size(); ++g) {
    std::vector<std::array<uint32_t, 3>> mine;
    for (size_t t = 0; t < T.size(); ++t)
      if (group[t] == g) mine.push_back(T[t]);
    const auto expected = mesh::check_surface(mine, on_curve);
    CHECK(checks.interfaces[g].nonmanifold_edges == expected.nonmanifold_edges);
    CHECK(checks.interfaces[g].boundary_edges == expected.boundary_edges);
    CHECK(checks.interfaces[g].open_edges == expected.open_edges);
    nonmanifold += expected.nonmanifold_edges;
    open += expected.open_edges;
    const auto stats = mesh::triangle_stats(V, mine);
    const auto got = sums[g].stats();
    CHECK(got.triangles == mine.size());
    CHECK(got.mean_radius_ratio == doctest::Approx(stats.mean_radius_ratio).epsilon(1e-12));
    CHECK(got.min_radius_ratio == stats.min_radius_ratio);
    CHECK(got.share_below_half == stats.share_below_half);
    CHECK(one_thread[g].sum == sums[g].sum);  // fixed chunks: the same sums on any thread count
  }
  CHECK(nonmanifold > 0);
  CHECK(open > 0);
  size_t odd = 0;
  for (uint16_t m = 0; m < 5; ++m) {
    std::vector<std::array<uint32_t, 3>> boundary;
    for (size_t t = 0; t < T.size(); ++t)
      if (pairs[group[t]][0] == m || pairs[group[t]][1] == m) boundary.push_back(T[t]);
    CHECK(checks.odd_edges[m] == mesh::odd_edges(boundary));
    odd += checks.odd_edges[m];
  }
  CHECK(odd > 0);
}

TEST_CASE("nonconforming_faces: two tets of two materials agree with their interface triangles, and not once one is gone or relabelled") {
  // Tets (0, 1, 2, 3) of material 1 and (1, 2, 3, 4) of material 2 share the face (1, 2, 3); their other faces lie on
  // the outside, material 0.
  const std::vector<glm::dvec3> P = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  const std::vector<std::array<uint32_t, 4>> tets = {{0, 1, 2, 3}, {1, 2, 3, 4}};
  std::vector<uint16_t> material = {1, 2};
  std::vector<std::array<uint32_t, 3>> triangles = {{1, 2, 3}, {0, 1, 2}, {0, 1, 3}, {0, 2, 3}, {1, 2, 4}, {1, 3, 4}, {2, 3, 4}};
  std::vector<std::array<uint16_t, 2>> pair = {{1, 2}, {0, 1}, {0, 1}, {0, 1}, {0, 2}, {0, 2}, {0, 2}};
  CHECK(mesh::nonconforming_faces(P, tets, material, triangles, pair).mismatches == 0);
  SUBCASE("the interface triangle between them missing") {
    triangles.erase(triangles.begin());
    pair.erase(pair.begin());
    const auto c = mesh::nonconforming_faces(P, tets, material, triangles, pair);
    CHECK(c.mismatches == 1);
    CHECK(glm::length(c.first - glm::dvec3(1.0 / 3)) < 1e-12);  // the centroid of (1, 2, 3)
  }
  SUBCASE("the second tet of the first material: the shared face is no interface, its outer faces have another pair") {
    material[1] = 1;
    CHECK(mesh::nonconforming_faces(P, tets, material, triangles, pair).mismatches == 7);
  }
}

TEST_CASE("tet_materials: a tet in no named region takes its neighbours' material, else its interfaces' side, else the fallback's") {
  // Tet A = (0, 1, 2, 3) of region 2 (material 1) and B = (1, 2, 3, 4) of region 3 (material 2) share the interface
  // triangle (1, 2, 3), oriented from material 1 into 2; C = (0, 1, 2, 5) lies below A across the face (0, 1, 2),
  // which is no interface triangle, at region 0 (TetGen left one such tet in thin-128's material 40).
  mesh::Tets V;
  V.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}, {0.3, 0.3, -1}};
  V.tets = {{0, 1, 2, 3}, {1, 2, 3, 4}, {0, 1, 2, 5}};
  V.region = {2, 3, 0};
  std::vector<std::array<uint32_t, 3>> triangles = {{1, 2, 3}};
  const std::vector<std::array<uint16_t, 2>> pair = {{1, 2}};
  auto never = [](uint32_t) -> uint16_t { FAIL("the fallback is not asked"); return 0; };
  CHECK(mesh::tet_materials(V, triangles, pair, 3, never) == std::vector<uint16_t>{1, 2, 1});
  SUBCASE("A and C unnamed: they take the side of (1, 2, 3) they lie on") {
    V.region = {0, 3, 7};  // 7: a region TetGen numbered, past the materials
    CHECK(mesh::tet_materials(V, triangles, pair, 3, never) == std::vector<uint16_t>{1, 2, 1});
    triangles[0] = {1, 3, 2};  // turned round: A and C are on material 2's side
    CHECK(mesh::tet_materials(V, triangles, pair, 3, never) == std::vector<uint16_t>{2, 2, 2});
  }
  SUBCASE("nothing named, no interface: the fallback's vote over the part") {
    V.region.clear();
    triangles.clear();
    CHECK(mesh::tet_materials(V, triangles, {}, 3, [](uint32_t t) { return uint16_t(t == 1 ? 0 : 2); }) ==
          std::vector<uint16_t>{2, 2, 2});
  }
}
