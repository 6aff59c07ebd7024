// mesh::collapse_interface_edges on a patch of the equilateral lattice in the plane z = 0 with one inner vertex moved
// most of the way to its neighbour (a short edge and two flat triangles): the collapse removes one of the two, leaving
// fair triangles, every orientation and every edge's two triangles; a quadruple point stays where a vertex of a
// lesser feature would go, and a long edge or no passes leaves the mesh as it is.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "fields/closest_point_embedding.h"
#include "mesh/interface_collapses.h"
#include "mesh/interface_flips.h"
#include "mesh/quality.h"
#include "lattice.h"

using namespace cpmesh;

namespace {

constexpr int kColumns = 7, kRows = 7;

uint32_t at(int i, int j) { return uint32_t(j * kColumns + i); }

mesh::InterfaceMesh lattice() { return test::lattice(kColumns, kRows); }

// (3, 3) moved 80% of the way to (4, 3): their edge is 0.2 long.
mesh::InterfaceMesh crowded() {
  mesh::InterfaceMesh m = lattice();
  m.vertices[at(3, 3)] += 0.8 * (m.vertices[at(4, 3)] - m.vertices[at(3, 3)]);
  return m;
}

bool uses_vertex(const mesh::InterfaceMesh& m, uint32_t v) {
  return std::any_of(m.triangles.begin(), m.triangles.end(),
                     [&](const auto& t) { return std::count(t.begin(), t.end(), v) > 0; });
}

const std::vector<float> kH(kColumns * kRows, 1.0f);

// Three half-lattices of kColumns x 4 rows meeting along the x axis (row 0, a triple curve of materials 0, 1, 2):
// z = 0 for y > 0 (interface 0/1) and y < 0 (0/2), and y = 0 for z > 0 (1/2).
mesh::InterfaceMesh three_sheets() {
  mesh::InterfaceMesh m;
  for (int i = 0; i < kColumns; ++i) m.vertices.push_back({double(i), 0.0, 0.0});
  m.vertex_kind.assign(kColumns, uint8_t(fields::FeatureKind::triple_curve));
  const std::array<glm::dvec3, 3> out = {glm::dvec3(0, 1, 0), glm::dvec3(0, -1, 0), glm::dvec3(0, 0, 1)};
  const std::array<std::array<uint16_t, 2>, 3> pairs = {{{0, 1}, {0, 2}, {1, 2}}};
  for (int s = 0; s < 3; ++s) {
    auto at_sheet = [&](int i, int j) { return j == 0 ? uint32_t(i) : uint32_t(kColumns * (1 + 3 * s + j - 1) + i); };
    for (int j = 1; j < 4; ++j)
      for (int i = 0; i < kColumns; ++i) {
        m.vertices.push_back(glm::dvec3(i + 0.5 * (j % 2), 0, 0) + j * test::kRowHeight * out[size_t(s)]);
        m.vertex_kind.push_back(uint8_t(fields::FeatureKind::interface));
      }
    test::add_lattice_triangles(m, kColumns, 4, at_sheet, pairs[size_t(s)]);
  }
  m.face.assign(m.triangles.size(), 7);
  return m;
}

// Edges in three triangles, each of another interface.
size_t curve_edges(const mesh::InterfaceMesh& m) {
  std::map<std::pair<uint32_t, uint32_t>, std::vector<std::array<uint16_t, 2>>> on;
  for (size_t t = 0; t < m.triangles.size(); ++t)
    for (int i = 0; i < 3; ++i) {
      const uint32_t u = m.triangles[t][size_t(i)], v = m.triangles[t][size_t((i + 1) % 3)];
      on[{std::min(u, v), std::max(u, v)}].push_back(m.pair[t]);
    }
  size_t n = 0;
  for (auto& [e, pairs] : on) {
    std::sort(pairs.begin(), pairs.end());
    n += pairs.size() == 3 && std::adjacent_find(pairs.begin(), pairs.end()) == pairs.end();
  }
  return n;
}

}  // namespace

TEST_CASE("collapse_interface_edges: the crowded vertex goes and fair triangles are left") {
  mesh::InterfaceMesh m = crowded();
  const size_t triangles = m.triangles.size();
  REQUIRE(test::worst_ratio(m) < 0.4);
  const auto r = mesh::collapse_interface_edges(m, kH);
  CHECK(r.collapses == 1);
  CHECK(r.undone == 0);
  CHECK(m.triangles.size() == triangles - 2);
  CHECK(m.pair.size() == m.triangles.size());
  CHECK(m.face.size() == m.triangles.size());
  CHECK(uses_vertex(m, at(3, 3)) != uses_vertex(m, at(4, 3)));  // one of the two left
  CHECK(test::worst_ratio(m) > 0.6);
  CHECK(test::every_normal_up(m));
  CHECK(mesh::odd_edges(m.triangles) == mesh::odd_edges(lattice().triangles));
  CHECK(std::count(m.face.begin(), m.face.end(), mesh::kNoFace) == 4);  // the changed ones
  CHECK(mesh::collapse_interface_edges(m, kH).collapses == 0);  // nothing left to gain
}

TEST_CASE("collapse_interface_edges: a crowded vertex standing out of its sheet goes, and the sheet comes out flat") {
  mesh::InterfaceMesh m = crowded();
  m.vertices[at(3, 3)].z = 0.2;  // its triangles tilt by up to 45 degrees
  CHECK(mesh::collapse_interface_edges(m, kH).collapses == 1);
  CHECK(test::worst_ratio(m) > 0.6);
  CHECK(test::every_normal_up(m));
}

TEST_CASE("collapse_interface_edges: a quadruple point stays, a long edge or no passes changes nothing") {
  SUBCASE("the moved vertex a quadruple point: its neighbour joins it") {
    mesh::InterfaceMesh m = crowded();
    m.vertex_kind[at(3, 3)] = uint8_t(fields::FeatureKind::quadruple_point);
    CHECK(mesh::collapse_interface_edges(m, kH).collapses == 1);
    CHECK(uses_vertex(m, at(3, 3)));
    CHECK(!uses_vertex(m, at(4, 3)));
  }
  SUBCASE("both quadruple points") {
    mesh::InterfaceMesh m = crowded();
    m.vertex_kind[at(3, 3)] = m.vertex_kind[at(4, 3)] = uint8_t(fields::FeatureKind::quadruple_point);
    CHECK(mesh::collapse_interface_edges(m, kH).collapses == 0);
  }
  SUBCASE("the edge longer than max_length x h") {
    mesh::InterfaceMesh m = crowded();
    const std::vector<float> small(kH.size(), 0.25f);  // 0.2 > 0.7 x 0.25
    CHECK(mesh::collapse_interface_edges(m, small).collapses == 0);
    CHECK(m.triangles == crowded().triangles);
  }
  SUBCASE("no passes") {
    mesh::InterfaceMesh m = crowded();
    mesh::CollapseOptions o;
    o.passes = 0;
    CHECK(mesh::collapse_interface_edges(m, kH, o).collapses == 0);
  }
}

TEST_CASE("collapse_interface_edges: a crowded curve vertex goes along its curve, and the curve stays whole") {
  mesh::InterfaceMesh m = three_sheets();
  REQUIRE(curve_edges(m) == kColumns - 1);
  m.vertices[3] += 0.8 * (m.vertices[4] - m.vertices[3]);
  const std::vector<float> h(m.vertices.size(), 1.0f);
  const size_t triangles = m.triangles.size();
  CHECK(mesh::collapse_interface_edges(m, h).collapses == 1);
  CHECK(m.triangles.size() == triangles - 3);  // one of each interface on the curve edge
  CHECK(uses_vertex(m, 3) != uses_vertex(m, 4));
  CHECK(curve_edges(m) == kColumns - 2);  // the curve runs through the other one
  CHECK(test::worst_ratio(m) > 0.6);
}
