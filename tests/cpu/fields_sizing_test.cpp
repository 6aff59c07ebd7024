// Sizing field on analytic volumes: curvature-limited on a sphere, thickness-limited on a thin slab, graded.
#include <doctest/doctest.h>

#include "fields/sizing_field.h"
#include "fields_volumes.h"

using namespace cpmesh;
using namespace cpmesh::fields;

TEST_CASE("spheres of radius 4 to 20: h on the surface is density x R within 15% everywhere") {
  // A voxelised sphere's flat caps and their rims are several voxels wide: a curvature fitted within a few voxels
  // read them as radii from 0.66 R to 1.28 R (R = 20). The fit at 0.4 R from the normals sees the sphere.
  for (const double radius : {4.0, 8.0, 20.0}) {
    CAPTURE(radius);
    const auto vol = test::make_volume(io::SynthShape::sphere, int(2 * radius) + 16, radius);
    const auto F = build_indicator_fields(vol.grid, vol.labels.data());
    auto E = build_closest_point_embedding(F);
    SizingOptions opt;
    opt.density = 0.25;
    opt.h_max = 100.0;  // let curvature decide
    const auto stats = compute_sizing_field(F, E, opt);
    const double expected = opt.density * radius;
    MESSAGE("R " << radius << ": h min " << stats.h_min << " mean " << stats.h_mean << " max " << stats.h_max
                 << "; curvature-limited " << stats.curvature_limited << ", thickness-limited "
                 << stats.thickness_limited);
    size_t outside = 0;
    for (const auto& p : E.fine) outside += std::fabs(p.w - expected) > 0.15 * expected;
    CHECK(outside == 0);
    CHECK(stats.h_mean == doctest::Approx(expected).epsilon(0.05));
    CHECK(stats.curvature_limited > 0);
  }
}

TEST_CASE("a thin slab limits h by its thickness, and h is graded away from it") {
  // Material 1 is a slab 3 voxels thick (z = 10..12) in background 0; far from it h reaches h_max.
  fields::Grid g{{24, 24, 24}, {1, 1, 1}, {0, 0, 0}};
  std::vector<uint16_t> labels(g.voxel_count());
  for (int k = 0; k < 24; ++k)
    for (int j = 0; j < 24; ++j)
      for (int i = 0; i < 24; ++i) labels[g.index(i, j, k)] = (k >= 10 && k <= 12) ? 1 : 0;
  const auto F = build_indicator_fields(g, labels.data());
  auto E = build_closest_point_embedding(F);
  SizingOptions opt;
  opt.density = 1.0;
  opt.h_max = 4.0;
  const auto stats = compute_sizing_field(F, E, opt);
  // The slab's medial plane is 1.5 voxels from each face: h about 1.5 on the faces.
  CHECK(stats.thickness_limited > 0);
  CHECK(stats.h_mean == doctest::Approx(1.5).epsilon(0.25));
  // Grading: no two fine points closer than a voxel differ by more than the Lipschitz bound (plus rounding).
  for (size_t a = 0; a + 1 < E.fine.size(); a += 7) {
    const auto& p = E.fine[a];
    const auto& q = E.fine[a + 1];
    const double d = glm::length(glm::vec3(p) - glm::vec3(q));
    CHECK(std::fabs(p.w - q.w) <= opt.grading * d + 0.3);
  }
}
