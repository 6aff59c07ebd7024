// mesh::smooth_interfaces on the restricted Delaunay mesh of random points on a sphere (a poor mesh on purpose):
// quality goes up, the worst triangle does not get worse, vertices stay on the surface, connectivity is unchanged.
#include <doctest/doctest.h>

#include <random>

#include "fields/fields_stage.h"
#include "fields_volumes.h"
#include "mesh/extract.h"
#include "mesh/quality.h"
#include "mesh/smooth.h"
#include "mesh/tetgen.h"
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
