// mesh::insert_points (Bowyer-Watson) against TetGen: inserting points into a Delaunay tetrahedralization gives the
// tetrahedralization of all the points (unique in general position), with a consistent adjacency.
#include <doctest/doctest.h>

#include <algorithm>
#include <random>

#include "mesh/extract.h"
#include "mesh/tetgen.h"

using namespace cpmesh;

namespace {

std::vector<std::array<uint32_t, 4>> sorted_tets(const mesh::Tets& T) {
  auto tets = T.tets;
  for (auto& t : tets) std::sort(t.begin(), t.end());
  std::sort(tets.begin(), tets.end());
  return tets;
}

}  // namespace

TEST_CASE("insert_points: TetGen's tets of the first points plus inserted ones equal TetGen's tets of all points") {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0.0, 10.0);
  // A cube's corners first (the hull), then random points inside: every later point is inside the hull.
  std::vector<glm::dvec3> points;
  for (int c = 0; c < 8; ++c) points.push_back(glm::dvec3(c & 1 ? 10.5 : -0.5, c & 2 ? 10.5 : -0.5, c & 4 ? 10.5 : -0.5));
  for (int i = 0; i < 3000; ++i) points.push_back(glm::dvec3(u(rng), u(rng), u(rng)));
  const size_t first = 2000;
  mesh::Tets T = mesh::delaunay(std::vector<glm::dvec3>(points.begin(), points.begin() + first));
  mesh::Adjacency adj = mesh::build_adjacency(T);
  // Start the walks far away (tet 0) for half of them, next to the last tet for the rest.
  std::vector<uint32_t> near(points.size() - first, 0);
  for (size_t i = 0; i < near.size(); i += 2) near[i] = uint32_t(T.tets.size() - 1);
  REQUIRE(mesh::insert_points(T, adj, std::vector<glm::dvec3>(points.begin() + first, points.end()), near));
  CHECK(T.points == points);
  CHECK(T.neighbours.empty());
  const mesh::Tets all = mesh::delaunay(points);
  CHECK(T.tets.size() == all.tets.size());
  CHECK(sorted_tets(T) == sorted_tets(all));
  // The adjacency kept up to date equals the one found by sorting the faces.
  mesh::Tets plain = T;
  const mesh::Adjacency sorted = mesh::build_adjacency(plain);
  CHECK(adj.neighbour == sorted.neighbour);
  // Every tet keeps its orientation sign.
  size_t flat = 0, flipped = 0;
  const double sign = mesh::orient3d_exact(T.points[T.tets[0][0]], T.points[T.tets[0][1]], T.points[T.tets[0][2]],
                                           T.points[T.tets[0][3]]);
  for (const auto& t : T.tets) {
    const double o = mesh::orient3d_exact(T.points[t[0]], T.points[t[1]], T.points[t[2]], T.points[t[3]]);
    flat += o == 0;
    flipped += o * sign < 0;
  }
  CHECK(flat == 0);
  CHECK(flipped == 0);
}

TEST_CASE("insert_points: a point outside the hull or on a vertex is refused, and the mesh stays valid") {
  std::vector<glm::dvec3> points;
  for (int c = 0; c < 8; ++c) points.push_back(glm::dvec3(c & 1, c & 2 ? 1 : 0, c & 4 ? 1 : 0));
  points.push_back(glm::dvec3(0.4, 0.45, 0.5));
  mesh::Tets T = mesh::delaunay(points);
  mesh::Adjacency adj = mesh::build_adjacency(T);
  const auto before = sorted_tets(T);
  CHECK_FALSE(mesh::insert_points(T, adj, {glm::dvec3(2.0, 0.5, 0.5)}, {0}));
  CHECK(sorted_tets(T) == before);
  CHECK(T.points.size() == points.size());
  CHECK_FALSE(mesh::insert_points(T, adj, {glm::dvec3(0.4, 0.45, 0.5)}, {0}));
  CHECK(sorted_tets(T) == before);
  CHECK(mesh::insert_points(T, adj, {glm::dvec3(0.6, 0.3, 0.7)}, {0}));
  CHECK(T.tets.size() > before.size());
}
