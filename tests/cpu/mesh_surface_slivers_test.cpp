// mesh::move_surface_vertices on a hand-built star: an interface vertex in the plane z = 0, pushed next to the edge
// of its ring so that its tets are slivers, surrounded by six ring vertices and an apex above and below (twelve
// tets). Only a move within the plane can mend them; with the apex below at a tenth of the ring's radius (a layer
// thinner than its triangles are long), only a move off the plane can.
#include <doctest/doctest.h>

#include <cmath>

#include "mesh/quality.h"
#include "mesh/surface_slivers.h"

using namespace cpmesh;

namespace {

struct Star {
  std::vector<glm::dvec3> points;  // 0: the centre, 1-6: the ring, 7: above, 8: below
  std::vector<std::array<uint32_t, 4>> tets;
  std::vector<std::array<uint32_t, 3>> triangles;  // the interface z = 0: the centre's fan
};

Star star(const glm::dvec3& centre, double below = -0.8) {
  Star s;
  s.points.push_back(centre);
  for (int i = 0; i < 6; ++i) s.points.push_back({std::cos(i * M_PI / 3), std::sin(i * M_PI / 3), 0.0});
  s.points.push_back({0, 0, 0.8});
  s.points.push_back({0, 0, below});
  for (uint32_t i = 0; i < 6; ++i) {
    const uint32_t a = 1 + i, b = 1 + (i + 1) % 6;
    s.triangles.push_back({0, a, b});
    s.tets.push_back({0, a, b, 7});
    s.tets.push_back({0, b, a, 8});
  }
  return s;
}

double smallest_angle_deg(const Star& s) {
  double worst = 180;
  for (const auto& t : s.tets) worst = std::min(worst, mesh::min_dihedral(s.points, t) * 180 / M_PI);
  return worst;
}

double signed_volume(const std::vector<glm::dvec3>& P, const std::array<uint32_t, 4>& t) {
  return glm::dot(P[t[1]] - P[t[0]], glm::cross(P[t[2]] - P[t[0]], P[t[3]] - P[t[0]]));
}

const mesh::FeatureProjection onto_plane = [](uint32_t, const glm::dvec3& near, glm::dvec3& on) {
  on = {near.x, near.y, 0.0};
  return true;
};

// Near the middle of the ring's edge from vertex 1 to vertex 2, 3% of the way in from it.
const glm::dvec3 kNearEdge = 0.97 * 0.5 * (glm::dvec3(1, 0, 0) + glm::dvec3(0.5, std::sqrt(0.75), 0));

}  // namespace

TEST_CASE("move_surface_vertices: an interface vertex next to its ring's edge moves within its plane until no tet is a sliver") {
  Star s = star(kNearEdge);
  const double before = smallest_angle_deg(s);
  REQUIRE(before < 12);
  const std::vector<glm::dvec3> start = s.points;
  const auto r = mesh::move_surface_vertices(s.points, s.tets, s.triangles, {1}, onto_plane);
  CHECK(r.slivers_before > 0);
  CHECK(r.moves > 0);
  CHECK(r.slivers_after == 0);
  CHECK(smallest_angle_deg(s) >= 12);  // measured here, not taken from the report
  CHECK(s.points[0].z == 0.0);
  for (size_t v = 1; v < s.points.size(); ++v) CHECK(s.points[v] == start[v]);
  for (const auto& t : s.tets) CHECK(signed_volume(s.points, t) * signed_volume(start, t) > 0);
  double worst_ratio = 1;
  for (const auto& t : s.triangles) worst_ratio = std::min(worst_ratio, mesh::radius_ratio(s.points[t[0]], s.points[t[1]], s.points[t[2]]));
  CHECK(worst_ratio >= 0.5);
}

TEST_CASE("move_surface_vertices: on the outer boundary (no tets below the plane), a move stands unless it crosses a triangle") {
  Star s = star(kNearEdge);
  std::erase_if(s.tets, [](const auto& t) { return t[3] == 8; });
  SUBCASE("nothing across the outside: it moves") {
    const auto r = mesh::move_surface_vertices(s.points, s.tets, s.triangles, {1}, onto_plane);
    CHECK(r.slivers_before > 0);
    CHECK(r.moves > 0);
    CHECK(r.slivers_after == 0);
    CHECK(smallest_angle_deg(s) >= 12);
  }
  SUBCASE("a triangle across the outside, under the plane, that the moved fan would cross: undone") {
    const uint32_t n = uint32_t(s.points.size());
    for (const glm::dvec3 p : {glm::dvec3(-3, -3, -0.02), glm::dvec3(3, -3, -0.02), glm::dvec3(0, 3, -0.02)})
      s.points.push_back(p);
    s.triangles.push_back({n, n + 1, n + 2});
    const mesh::FeatureProjection below = [](uint32_t, const glm::dvec3& near, glm::dvec3& on) {
      on = {near.x, near.y, -0.05};
      return true;
    };
    Star without = s;
    without.triangles.pop_back();
    CHECK(mesh::move_surface_vertices(without.points, without.tets, without.triangles, {1}, below).moves > 0);
    const auto r = mesh::move_surface_vertices(s.points, s.tets, s.triangles, {1}, below);
    CHECK(r.slivers_before > 0);
    CHECK(r.moves == 0);
    CHECK(s.points[0] == kNearEdge);
    CHECK(mesh::crossing_triangles(s.points, s.triangles).empty());
  }
}

TEST_CASE("move_surface_vertices: a vertex not movable, on the mesh's boundary, or whose projection fails stays") {
  SUBCASE("not movable") {
    Star s = star(kNearEdge);
    const auto r = mesh::move_surface_vertices(s.points, s.tets, s.triangles, {0}, onto_plane);
    CHECK(r.slivers_before == 0);  // no tet under the bound has a movable vertex
    CHECK(s.points[0] == kNearEdge);
  }
  SUBCASE("a tet below the plane is missing: its star is broken") {
    Star s = star(kNearEdge);
    s.tets.pop_back();
    const auto r = mesh::move_surface_vertices(s.points, s.tets, s.triangles, {1}, onto_plane);
    CHECK(r.slivers_before > 0);
    CHECK(r.moves == 0);
    CHECK(r.slivers_after == r.slivers_before);
    CHECK(s.points[0] == kNearEdge);
  }
  SUBCASE("the projection gives no point") {
    Star s = star(kNearEdge);
    const mesh::FeatureProjection nowhere = [](uint32_t, const glm::dvec3&, glm::dvec3&) { return false; };
    const auto r = mesh::move_surface_vertices(s.points, s.tets, s.triangles, {1}, nowhere);
    CHECK(r.moves == 0);
    CHECK(s.points[0] == kNearEdge);
  }
  SUBCASE("a projection off the plane would turn tets over: refused") {
    Star s = star(kNearEdge);
    const mesh::FeatureProjection far_up = [](uint32_t, const glm::dvec3& near, glm::dvec3& on) {
      on = {near.x, near.y, 2.0};  // above the apex
      return true;
    };
    const auto r = mesh::move_surface_vertices(s.points, s.tets, s.triangles, {1}, far_up);
    CHECK(r.moves == 0);
    CHECK(s.points[0] == kNearEdge);
  }
}

TEST_CASE("move_surface_vertices: over a layer thinner than its triangles, the vertex leaves its plane by at most the offset") {
  constexpr double kBelow = -0.1, kOffset = 0.25;
  Star s = star({0, 0, 0}, kBelow);
  REQUIRE(smallest_angle_deg(s) < 12);
  SUBCASE("no offset: no place on the plane mends the tets below") {
    const auto r = mesh::move_surface_vertices(s.points, s.tets, s.triangles, {1}, onto_plane, {.max_offset = 0.0});
    CHECK(r.slivers_after == r.slivers_before);
    CHECK(s.points[0].z == 0.0);
    CHECK(smallest_angle_deg(s) < 12);
  }
  SUBCASE("an offset: it moves up, away from the apex below") {
    const std::vector<glm::dvec3> start = s.points;
    const auto r = mesh::move_surface_vertices(s.points, s.tets, s.triangles, {1}, onto_plane, {.max_offset = kOffset});
    CHECK(r.slivers_after == 0);
    CHECK(smallest_angle_deg(s) >= 12);
    CHECK(s.points[0].z > 0.0);
    CHECK(s.points[0].z <= kOffset + 1e-12);
    for (const auto& t : s.tets) CHECK(signed_volume(s.points, t) * signed_volume(start, t) > 0);
  }
}

TEST_CASE("move_surface_vertices: a flat interface triangle over fair tets is mended within its plane by min_ratio") {
  // 80% of the way to the edge's middle: the triangle on that edge has radius ratio 0.21, the tets are all over 15
  // degrees, so only the ratio bound moves the vertex.
  const glm::dvec3 near_edge = 0.8 * 0.5 * (glm::dvec3(1, 0, 0) + glm::dvec3(0.5, std::sqrt(0.75), 0));
  auto smallest_ratio = [](const Star& s) {
    double worst = 1;
    for (const auto& t : s.triangles)
      worst = std::min(worst, mesh::radius_ratio(s.points[t[0]], s.points[t[1]], s.points[t[2]]));
    return worst;
  };
  Star s = star(near_edge);
  REQUIRE(smallest_angle_deg(s) > 15);
  REQUIRE(smallest_ratio(s) < 0.25);
  SUBCASE("no ratio bound: nothing to mend") {
    const auto r = mesh::move_surface_vertices(s.points, s.tets, s.triangles, {1}, onto_plane);
    CHECK(r.flat_before == 0);
    CHECK(r.moves == 0);
    CHECK(s.points[0] == near_edge);
  }
  SUBCASE("a bound of 0.3: the vertex moves in its plane until every triangle is over it") {
    const auto r = mesh::move_surface_vertices(s.points, s.tets, s.triangles, {1}, onto_plane, {.min_ratio = 0.3});
    CHECK(r.flat_before == 1);
    CHECK(r.flat_after == 0);
    CHECK(smallest_ratio(s) >= 0.3);
    CHECK(smallest_angle_deg(s) >= 12);
    CHECK(s.points[0].z == 0.0);
  }
  SUBCASE("a quadruple point (no feature to follow) moves only by the offset, and not without one") {
    const auto r = mesh::move_surface_vertices(s.points, s.tets, s.triangles, {3}, onto_plane, {.min_ratio = 0.3});
    CHECK(r.moves == 0);
    CHECK(s.points[0] == near_edge);
    Star t = star(near_edge);
    const auto o = mesh::move_surface_vertices(t.points, t.tets, t.triangles, {3}, onto_plane,
                                               {.max_offset = 0.25, .min_ratio = 0.3});
    CHECK(o.moves > 0);
    CHECK(smallest_ratio(t) > smallest_ratio(s));
    CHECK(glm::length(t.points[0] - near_edge) <= 0.25 + 1e-12);
  }
}
