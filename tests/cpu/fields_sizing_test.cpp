// Sizing field on analytic volumes: curvature-limited on a sphere, thickness-limited on a thin slab, graded.
#include <doctest/doctest.h>

#include "fields/curve_fit.h"
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
  // The slab's medial plane is 1.5 voxels from each face: h about 1.5 on the faces. The fine points on that plane
  // are as far from one face as from the other; Newton stalls there (the gradient of f_1 - f_0 vanishes), and the
  // points it left behind, mid-slab, once read as a layer a fraction of a voxel thick: h down to h_min (0.25) around
  // them, mean 1.36.
  MESSAGE("h: min " << stats.h_min << " mean " << stats.h_mean << " max " << stats.h_max);
  CHECK(stats.thickness_limited > 0);
  CHECK(stats.h_mean == doctest::Approx(1.5).epsilon(0.1));
  CHECK(stats.h_min > 1.0);
  // Every closest point on a face, away from the volume's sides (where the fields see the slab end).
  for (const auto& p : E.fine)
    if (std::min({p.x, p.y, 23.0f - p.x, 23.0f - p.y}) > 3.0f) CHECK(std::fabs(std::fabs(p.z - 11.0) - 1.5) < 0.25);
  // Grading: no two fine points closer than a voxel differ by more than the Lipschitz bound (plus rounding).
  for (size_t a = 0; a + 1 < E.fine.size(); a += 7) {
    const auto& p = E.fine[a];
    const auto& q = E.fine[a + 1];
    const double d = glm::length(glm::vec3(p) - glm::vec3(q));
    CHECK(std::fabs(p.w - q.w) <= opt.grading * d + 0.3);
  }
  // The walk along the normal stops where the half thickness could no longer bring h under h_max: at h_max 2 the
  // slab's 1.5 still limits h (its crossing, 3 voxels in, is within 2 h_max / density = 4), on the same blocks.
  SizingOptions low = opt;
  low.h_max = 2.0;
  auto E_low = build_closest_point_embedding(F);
  const auto low_stats = compute_sizing_field(F, E_low, low);
  CHECK(low_stats.thickness_limited == stats.thickness_limited);
  CHECK(low_stats.h_min == stats.h_min);
}

TEST_CASE("grading spreads a thin part's small h along the surface at the grading rate, and no further") {
  // Material 1 is 3 voxels thick (z = 10..12) for x < 12 and 12 voxels thick (z = 10..21) beyond: its bottom face
  // z = 9.5 runs flat across the step. On the thin part h is about 1.5 (its half thickness, density 1); on the thick
  // part it would be 6, clamped to h_max = 4, but grading caps it at about 1.5 + grading x the distance to the step.
  fields::Grid g{{36, 24, 32}, {1, 1, 1}, {0, 0, 0}};
  std::vector<uint16_t> labels(g.voxel_count());
  for (int k = 0; k < 32; ++k)
    for (int j = 0; j < 24; ++j)
      for (int i = 0; i < 36; ++i) labels[g.index(i, j, k)] = (k >= 10 && k <= (i < 12 ? 12 : 21)) ? 1 : 0;
  const auto F = build_indicator_fields(g, labels.data());
  auto E = build_closest_point_embedding(F);
  SizingOptions opt;
  opt.density = 1.0;
  opt.h_max = 4.0;
  compute_sizing_field(F, E, opt);
  size_t near_step = 0, far = 0;
  for (const auto& p : E.fine) {
    if (std::fabs(p.z - 9.5f) > 0.25f || p.y < 5.0f || p.y > 18.0f) continue;  // the bottom face, away from the sides
    const double d = p.x - 11.5;  // from the step
    if (d >= 0.5 && d <= 4.0) {
      ++near_step;
      // Paths of 26-neighbour steps are at most 8% longer than straight; the thin part's h near the step and the
      // interpolation between cells add the rest.
      CHECK(p.w <= 1.5 + opt.grading * 1.08 * d + 0.6);
    }
    if (d >= 10.0 && p.x <= 30.0f) {
      ++far;
      CHECK(p.w >= 3.5);  // grading lowers h only as far as it must
    }
  }
  CHECK(near_step > 20);
  CHECK(far > 20);
}

TEST_CASE("fit_local_curve: a circle's curvature and a line's") {
  for (const double radius : {4.0, 6.0, 12.0}) {
    CAPTURE(radius);
    std::vector<glm::dvec3> points;
    for (int k = 0; k < 64; ++k) {
      const double a = 2 * M_PI * k / 64;
      points.emplace_back(radius * std::cos(a), radius * std::sin(a), 0.1 * radius);
    }
    std::vector<uint32_t> near;
    for (uint32_t j = 0; j < points.size(); ++j)
      if (glm::length(points[j] - points[0]) < 6.0) near.push_back(j);
    const LocalCurve fit = fit_local_curve(points, near, 0, 2.0);
    REQUIRE(fit.valid);
    // Within 10% where the window (3 sigma = 6) spans under a radian each way; on a tighter circle the quadratic
    // reads it tighter still (1.42x at radius 4), never looser, so h errs towards more particles.
    if (radius >= 6.0)
      CHECK(fit.curvature * radius == doctest::Approx(1.0).epsilon(0.1));
    else
      CHECK((fit.curvature * radius > 1.0 && fit.curvature * radius < 1.5));
    CHECK(glm::length(fit.offset) < 0.05 * radius);
  }
  std::vector<glm::dvec3> line;
  for (int k = -6; k <= 6; ++k) line.emplace_back(0.5 * k, 0.3 * k, -0.2 * k);
  std::vector<uint32_t> all(line.size());
  for (uint32_t j = 0; j < all.size(); ++j) all[j] = j;
  const LocalCurve straight = fit_local_curve(line, all, 6, 2.0);
  REQUIRE(straight.valid);
  CHECK(straight.curvature < 1e-9);
  CHECK(straight.rms < 1e-9);
}

TEST_CASE("wedge ball: a triple curve's own curvature bounds h along it, and so does its chord error") {
  // The inner ball's curves are circles smaller than the ball (the wedge planes miss its centre); a spacing set by
  // the ball alone put chords 0.5 voxel off them at 48^3. Curve particles settle about 1.4 h apart, so a chord
  // tolerance c keeps 1.4 h <= sqrt(8 r c) (sizing_field.cpp).
  const auto wb = test::make_volume(io::SynthShape::wedge_ball, 48);
  const auto F = build_indicator_fields(wb.grid, wb.labels.data());
  auto E = build_closest_point_embedding(F);
  auto E_no_chord = E;
  SizingOptions no_chord;
  no_chord.curve_chord = 0;
  const auto stats = compute_sizing_field(F, E, SizingOptions{});
  compute_sizing_field(F, E_no_chord, no_chord);
  CHECK(stats.curve_limited > 0);
  size_t chord_bound = 0;
  // Each analytic curve's radius: the circumradius of its first, middle and last points (all curves here are arcs
  // of circles or straight segments).
  for (const auto& curve : wb.junctions.triple_curves) {
    const auto& pts = curve.points;
    const glm::dvec3 a(pts.front()[0], pts.front()[1], pts.front()[2]);
    const glm::dvec3 b(pts[pts.size() / 2][0], pts[pts.size() / 2][1], pts[pts.size() / 2][2]);
    const glm::dvec3 c(pts.back()[0], pts.back()[1], pts.back()[2]);
    const double area2 = glm::length(glm::cross(b - a, c - a));
    if (area2 < 1e-6) continue;  // straight
    const double radius = glm::length(b - a) * glm::length(c - b) * glm::length(a - c) / (2.0 * area2);
    const int fid = E.feature_index(FeatureKind::triple_curve, {curve.materials[0], curve.materials[1], curve.materials[2], 0xffff});
    REQUIRE(fid >= 0);
    // Median h at the curve's points away from its ends (quadruple points take the h of everything around them).
    auto median_h = [&](const ClosestPointEmbedding& emb) {
      std::vector<double> h;
      for (size_t slot = 0; slot < emb.keys.size(); ++slot) {
        if (emb.keys[slot] == ClosestPointEmbedding::kEmpty || int(emb.keys[slot] & 0xffff) != fid) continue;
        const size_t b = emb.blocks[slot];
        const glm::dvec3 p(glm::vec3(emb.fine[b * 8]));
        const double to_end = std::min(glm::length(p - (a - wb.grid.origin)), glm::length(p - (c - wb.grid.origin)));
        if (to_end > 4.0) h.push_back(emb.fine[b * 8].w);
      }
      REQUIRE(!h.empty());
      std::sort(h.begin(), h.end());
      return h[h.size() / 2];
    };
    const double h = median_h(E), h_no_chord = median_h(E_no_chord);
    const double bound = std::sqrt(8 * radius * SizingOptions{}.curve_chord) / 1.4;  // 1.4: sizing_field.cpp
    MESSAGE("curve " << curve.materials[0] << curve.materials[1] << curve.materials[2] << ": radius " << radius
                     << ", h median " << h << " (chord bound " << bound << "), without the chord bound " << h_no_chord);
    CHECK(h <= 0.5 * radius * 1.1);
    CHECK(h <= bound * 1.1);
    CHECK(h_no_chord <= 0.5 * radius * 1.1);
    if (bound < 0.9 * h_no_chord) {  // the chord bound is the tighter one: it must have lowered h
      CHECK(h < 0.9 * h_no_chord);
      ++chord_bound;
    }
  }
  CHECK(chord_bound == 3);  // the three inner-ball curves (h 2.18-2.35 instead of 2.83-3.27); elsewhere the surfaces
                            // set a smaller h
}
