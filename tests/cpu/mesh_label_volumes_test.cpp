// mesh::match_label_volumes on an icosphere of material 1 in material 0 (the normals pointing from 0 into 1): a ball
// short of its target grows along its normals to it, by the same distance everywhere; one within the tolerance stays;
// the growth stops at the largest move; junction vertices stay where they are; an open material is not closed.
#include <doctest/doctest.h>

#include <cmath>

#include "fields/closest_point_embedding.h"
#include "icosphere.h"
#include "mesh/label_volumes.h"

using namespace cpmesh;

namespace {

constexpr double kRadius = 5.0;

mesh::InterfaceMesh ball() {
  const test::Sphere s = test::icosphere(kRadius, 3, /*inward=*/true);
  mesh::InterfaceMesh m;
  m.vertices = s.points;
  m.triangles = s.triangles;
  m.pair.assign(m.triangles.size(), {0, 1});
  return m;
}

std::vector<uint8_t> interface_kinds(size_t n) { return std::vector<uint8_t>(n, uint8_t(fields::FeatureKind::interface)); }

}  // namespace

TEST_CASE("label volumes: a ball short of its target grows to it, evenly, and the outside is left to itself") {
  mesh::InterfaceMesh m = ball();
  const double before = mesh::enclosed_volumes(m, 2)[1];
  CHECK(before == doctest::Approx(test::enclosed_volume(m.vertices, m.triangles) * -1).epsilon(1e-12));
  CHECK(mesh::closed_materials(m, 2) == std::vector<uint8_t>{1, 1});
  const std::vector<double> target = {0.0, 1.05 * before};
  const auto r = mesh::match_label_volumes(m, interface_kinds(m.vertices.size()), target, {0, 1}, 1.0);
  CHECK(r.labels_moved == 1);
  CHECK(r.worst_before == doctest::Approx(0.05 / 1.05).epsilon(1e-9));
  CHECK(r.worst_after < 1e-3);
  CHECK(r.moves_undone == 0);
  CHECK(std::fabs(mesh::enclosed_volumes(m, 2)[1] - target[1]) < 1e-3 * target[1]);
  // Every vertex of the icosphere lay at kRadius and moved out along its normal by the same distance.
  const double grown = glm::length(m.vertices[0]) - kRadius;
  CHECK(grown > 0.05);
  for (const auto& p : m.vertices) CHECK(glm::length(p) - kRadius == doctest::Approx(grown).epsilon(1e-3));
}

TEST_CASE("label volumes: within the tolerance, or not measured, nothing moves; the move stops at max_move") {
  for (const auto& [share, measured] : {std::pair{1.005, uint8_t(1)}, std::pair{1.2, uint8_t(0)}}) {
    mesh::InterfaceMesh m = ball();
    const auto start = m.vertices;
    const auto r = mesh::match_label_volumes(m, interface_kinds(m.vertices.size()),
                                             {0.0, share * mesh::enclosed_volumes(m, 2)[1]}, {0, measured}, 1.0);
    CHECK(r.labels_moved == 0);
    CHECK(m.vertices == start);
  }
  // A quarter of a voxel of 0.4 is 0.1, less than any vertex's quarter of its shortest edge (0.16 at least).
  mesh::InterfaceMesh m = ball();
  const auto r = mesh::match_label_volumes(m, interface_kinds(m.vertices.size()),
                                           {0.0, 2.0 * mesh::enclosed_volumes(m, 2)[1]}, {0, 1}, 0.4);
  CHECK(r.labels_moved == 1);
  CHECK(r.worst_after == doctest::Approx(1 - std::pow(1.02, 3) / 2).epsilon(1e-2));  // (radius 5.1 against 5)
  for (const auto& p : m.vertices) CHECK(glm::length(p) == doctest::Approx(kRadius + 0.1).epsilon(1e-4));
}

TEST_CASE("label volumes: no vertex moves more than a quarter of its shortest edge") {
  mesh::InterfaceMesh m = ball();
  const auto start = m.vertices;
  std::vector<double> shortest(start.size(), 1e9);
  for (const auto& t : m.triangles)
    for (int c = 0; c < 3; ++c) {
      const uint32_t a = t[size_t(c)], b = t[size_t((c + 1) % 3)];
      const double length = glm::length(start[a] - start[b]);
      shortest[a] = std::min(shortest[a], length);
      shortest[b] = std::min(shortest[b], length);
    }
  mesh::match_label_volumes(m, interface_kinds(m.vertices.size()), {0.0, 2.0 * mesh::enclosed_volumes(m, 2)[1]},
                            {0, 1}, 10.0);
  for (size_t v = 0; v < start.size(); ++v) {
    const double moved = glm::length(m.vertices[v] - start[v]);
    CHECK(moved > 0.5 * 0.25 * shortest[v]);
    CHECK(moved <= 0.25 * shortest[v] * (1 + 1e-9));
  }
}

TEST_CASE("label volumes: junction vertices stay, the others make up for them") {
  mesh::InterfaceMesh m = ball();
  std::vector<uint8_t> kind = interface_kinds(m.vertices.size());
  for (size_t v = 0; v < kind.size(); v += 7) kind[v] = uint8_t(fields::FeatureKind::triple_curve);
  const auto start = m.vertices;
  const double target = 1.04 * mesh::enclosed_volumes(m, 2)[1];
  const auto r = mesh::match_label_volumes(m, kind, {0.0, target}, {0, 1}, 1.0);
  CHECK(r.worst_after < 0.01);
  for (size_t v = 0; v < kind.size(); v += 7) CHECK(m.vertices[v] == start[v]);
  CHECK(glm::length(m.vertices[1]) > kRadius);
}

TEST_CASE("label volumes: a material with a triangle missing is not closed, and is not moved") {
  mesh::InterfaceMesh m = ball();
  m.triangles.pop_back();
  m.pair.pop_back();
  CHECK(mesh::closed_materials(m, 2) == std::vector<uint8_t>{0, 0});
  const auto start = m.vertices;
  const auto r = mesh::match_label_volumes(m, interface_kinds(m.vertices.size()), {0.0, 1e6}, {0, 1}, 1.0);
  CHECK(r.labels_moved == 0);
  CHECK(r.worst_material == -1);
  CHECK(m.vertices == start);
}
