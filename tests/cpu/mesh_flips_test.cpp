// mesh::flip_interface_edges on a patch of the equilateral lattice in the plane z = 0, one interior edge turned to the
// long diagonal of its rhombus (two 30-30-120 triangles, radius ratio 0.46): the flip turns it back, keeping every
// triangle's orientation; a folded rhombus, or one whose triangles lie in two interfaces, stays.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "mesh/interface_flips.h"
#include "mesh/quality.h"
#include "lattice.h"

using namespace cpmesh;

namespace {

constexpr int kColumns = 6, kRows = 6;

uint32_t at(int i, int j) { return uint32_t(j * kColumns + i); }

mesh::InterfaceMesh lattice() { return test::lattice(kColumns, kRows); }

// The two triangles of the rhombus around the edge (2, 2)-(3, 2) of row 2 (an even row): below it (2, 2), (3, 2),
// (2, 3) and above (3, 2), (3, 3), (2, 3) share the edge (3, 2)-(2, 3); turned to the diagonal (2, 2)-(3, 3).
std::array<size_t, 2> turn_one_edge(mesh::InterfaceMesh& m) {
  std::array<size_t, 2> ts{};
  size_t n = 0;
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    const auto& tri = m.triangles[t];
    if (std::count(tri.begin(), tri.end(), at(3, 2)) && std::count(tri.begin(), tri.end(), at(2, 3))) ts[n++] = t;
  }
  REQUIRE(n == 2);
  m.triangles[ts[0]] = {at(2, 2), at(3, 2), at(3, 3)};
  m.triangles[ts[1]] = {at(2, 2), at(3, 3), at(2, 3)};
  return ts;
}

bool edges_manifold(const mesh::InterfaceMesh& m) {
  std::map<std::pair<uint32_t, uint32_t>, int> uses;
  for (const auto& t : m.triangles)
    for (int i = 0; i < 3; ++i) ++uses[{std::min(t[i], t[(i + 1) % 3]), std::max(t[i], t[(i + 1) % 3])}];
  return std::all_of(uses.begin(), uses.end(), [](const auto& u) { return u.second <= 2; });
}

}  // namespace

TEST_CASE("flip_interface_edges: the lattice with one long diagonal gets its short diagonal back") {
  mesh::InterfaceMesh m = lattice();
  REQUIRE(test::worst_ratio(m) > 0.999);
  const auto ts = turn_one_edge(m);
  REQUIRE(test::every_normal_up(m));
  REQUIRE(test::worst_ratio(m) < 0.47);
  const auto r = mesh::flip_interface_edges(m);
  CHECK(r.flips == 1);
  CHECK(r.undone == 0);
  CHECK(test::worst_ratio(m) > 0.999);
  CHECK(test::every_normal_up(m));
  CHECK(edges_manifold(m));
  CHECK(m.face[ts[0]] == mesh::kNoFace);
  CHECK(m.face[ts[1]] == mesh::kNoFace);
  CHECK(std::count(m.face.begin(), m.face.end(), mesh::kNoFace) == 2);
  CHECK(mesh::flip_interface_edges(m).flips == 0);  // nothing left to gain
}

TEST_CASE("flip_interface_edges: a folded rhombus, two interfaces, or no passes: no flip") {
  mesh::InterfaceMesh m = lattice();
  const auto ts = turn_one_edge(m);
  const auto before = m.triangles;
  SUBCASE("folded: one end of the short diagonal lifted out of the plane") {
    m.vertices[at(3, 2)].z = 0.6;
    CHECK(mesh::flip_interface_edges(m).flips == 0);
  }
  SUBCASE("the rhombus's triangles in two interfaces") {
    m.pair[ts[1]] = {0, 2};
    CHECK(mesh::flip_interface_edges(m).flips == 0);
  }
  SUBCASE("no passes") {
    mesh::FlipOptions o;
    o.passes = 0;
    CHECK(mesh::flip_interface_edges(m, o).flips == 0);
  }
  CHECK(m.triangles == before);
}
