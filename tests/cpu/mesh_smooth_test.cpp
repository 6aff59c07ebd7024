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
