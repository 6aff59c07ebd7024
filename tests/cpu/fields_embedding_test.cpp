// Closest point embedding on analytic volumes: the sphere (one interface) and a small wedge ball (9 interfaces,
// triple curves, 4 quadruple points), and the WENO4 lookup reference.
#include <doctest/doctest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include <tbb/global_control.h>

#include "fields/closest_point_embedding.h"
#include "fields/fields_stage.h"
#include "fields/volume_grid.h"
#include "fields/cp_lookup_gpu.h"
#include "ref/cp_lookup.h"
#include "fields_volumes.h"

using namespace cpmesh;
using namespace cpmesh::fields;

namespace {

// Largest distance between a WENO4 lookup and a direct Newton projection, over 500 queries within the embedding's band
// (0.75 voxel) of a sphere of radius 20 voxels.
double worst_lookup_error(const test::FieldsVolume& vol, const IndicatorFields& fields, const ClosestPointEmbedding& E) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n01;
  std::uniform_real_distribution<double> off(-0.75, 0.75);  // EmbeddingOptions::band
  double worst = 0;
  for (int i = 0; i < 500; ++i) {
    const glm::dvec3 dir = glm::normalize(glm::dvec3(n01(rng), n01(rng), n01(rng)));
    const glm::dvec3 q = vol.centre + dir * (20.0 + off(rng));
    const auto r = ref::cp_lookup(E, glm::vec3(q), 0);
    REQUIRE(r.valid);
    glm::dvec3 direct;
    REQUIRE(project_to_feature(fields, E.features[0], q, direct));
    worst = std::max(worst, glm::length(glm::dvec3(glm::vec3(r.value)) - direct));
  }
  return worst;
}

// Mean and largest distance of the embedding's stored triple-curve closest points to the analytic curves.
std::pair<double, double> curve_errors(const test::FieldsVolume& wb, const IndicatorFields& fields,
                                       const ClosestPointEmbedding& E) {
  double worst = 0, sum = 0;
  size_t n = 0;
  for (size_t slot = 0; slot < E.keys.size(); ++slot) {
    if (E.keys[slot] == ClosestPointEmbedding::kEmpty) continue;
    const Feature& f = E.features[E.keys[slot] & 0xffff];
    if (f.kind != FeatureKind::triple_curve) continue;
    for (int q = 0; q < 8; ++q) {
      const glm::dvec3 cp(glm::vec3(E.fine[size_t(E.blocks[slot]) * 8 + size_t(q)]));
      const double d = test::distance_to_curve(
          wb.junctions, {fields.labels[f.materials[0]], fields.labels[f.materials[1]], fields.labels[f.materials[2]]}, cp);
      worst = std::max(worst, d);
      sum += d;
      ++n;
    }
  }
  return {sum / double(std::max<size_t>(n, 1)), worst};
}

}  // namespace

TEST_CASE("WENO4 reproduces quadratics exactly and does not overshoot a step") {
  for (float t : {0.0f, 0.25f, 0.5f, 0.9f}) {
    auto q = [](float x) { return 3.0f + 2.0f * x - 0.5f * x * x; };
    CHECK(ref::weno4(q(-1), q(0), q(1), q(2), t) == doctest::Approx(q(t)).epsilon(1e-5));
    const float step = ref::weno4(0, 0, 1, 1, t);
    CHECK(step >= -1e-3f);
    CHECK(step <= 1.001f);
  }
  // Large offsets (coordinates far from the origin) keep float32 accuracy: indicators use differences.
  CHECK(ref::weno4(300.0f, 300.5f, 301.0f, 301.5f, 0.5f) == doctest::Approx(300.75f).epsilon(1e-7));
}

TEST_CASE("lookup step: the sizing stays within its four samples where WENO4 undershoots a valley") {
  // A one-sample valley of the sizing (thin layers): WENO4's quadratic pieces go below zero between the low samples,
  // and a negative h made NaN particles (ref/cp_lookup.h).
  CHECK(ref::weno4(4.0f, 0.25f, 0.25f, 4.0f, 0.5f) < 0.0f);
  const glm::vec4 f0(0, 5, 1, 4), f1(1, 5, 2, 0.25f), f2(2, 5, 4, 0.25f), f3(3, 5, 7, 4);
  for (float t = 0; t < 1.0f; t += 0.125f) {
    const glm::vec4 r = ref::weno4_lookup(f0, f1, f2, f3, t);
    CHECK(r.w >= 0.25f);
    CHECK(r.w <= 4.0f);
    CHECK(r.x == ref::weno4(0, 1, 2, 3, t));  // the closest point's components are not clamped
    CHECK(r.z == ref::weno4(1, 2, 4, 7, t));
  }
  // Within the samples' range nothing changes.
  const glm::vec4 g0(0, 0, 0, 1), g1(0, 0, 0, 1.5f), g2(0, 0, 0, 2), g3(0, 0, 0, 2.5f);
  CHECK(ref::weno4_lookup(g0, g1, g2, g3, 0.3f).w == ref::weno4(1, 1.5f, 2, 2.5f, 0.3f));
}

TEST_CASE("sphere R = 20: stored closest points lie on the smooth interface and near the true sphere") {
  const auto vol = test::make_volume(io::SynthShape::sphere, 56, 20.0);
  const auto fields = build_indicator_fields(vol.grid, vol.labels.data());
  const auto t0 = std::chrono::steady_clock::now();
  const auto E = build_closest_point_embedding(fields);
  MESSAGE("embedding: " << E.block_count() << " blocks, " << E.memory_bytes() / 1024 << " KiB, "
                        << std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() << " s");
  REQUIRE(E.features.size() == 1);
  CHECK(E.features[0].kind == FeatureKind::interface);
  CHECK(E.quadruple_points.empty());
  double worst_sphere = 0, worst_zero = 0;
  for (const auto& p : E.fine) {
    const glm::dvec3 cp(p);
    worst_sphere = std::max(worst_sphere, std::fabs(glm::length(cp - vol.centre) - 20.0));
    glm::dvec3 g1, g0;
    const double g = fields.fields[1].sample_cubic(cp, &g1) - fields.fields[0].sample_cubic(cp, &g0);
    worst_zero = std::max(worst_zero, std::fabs(g) / glm::length(g1 - g0));
  }
  MESSAGE("closest points: max distance to the true sphere " << worst_sphere << ", to the zero set " << worst_zero);
  CHECK(worst_sphere < 0.5);
  CHECK(worst_zero < 0.01);

  // Lookups near the surface agree with a direct Newton projection of the query point.
  const double worst_lookup = worst_lookup_error(vol, fields, E);
  MESSAGE("WENO4 lookup vs direct projection: max " << worst_lookup << " voxel");
  CHECK(worst_lookup < 0.02);
  // Far from the surface the stencil leaves the band and the lookup says so.
  CHECK_FALSE(ref::cp_lookup(E, glm::vec3(vol.centre), 0).valid);
  // A NaN or a far-off query finds nothing (it used to overflow the int conversion and read outside the table).
  CHECK_FALSE(ref::cp_lookup(E, glm::vec3(std::numeric_limits<float>::quiet_NaN()), 0).valid);
  CHECK_FALSE(ref::cp_lookup(E, glm::vec3(3e9f), 0).valid);
  CHECK_FALSE(ref::cp_lookup(E, glm::vec3(-3e9f), 0).valid);
}

TEST_CASE("automatic resolution: one fine point per voxel where the size floor is a voxel, with a deeper band") {
  FieldsOptions o;  // subcells and band left at 0: chosen
  const double voxel = 0.5;
  CHECK(resolve_fields_options(o, voxel).indicator.band == 4.0);  // default floor: a quarter voxel
  CHECK(embedding_subcells(o.embedding) == 2);
  o.sizing.h_min = 0.49;  // just under a voxel
  CHECK(resolve_fields_options(o, voxel).indicator.band == 4.0);
  CHECK(embedding_subcells(o.embedding, 0.98) == 2);
  o.sizing.h_min = 0.5;
  // Lookup band 0.75 plus the stencil's reach at S = 1 (2 sqrt 3 voxels) within 95% of the stored band, in whole voxels.
  auto r = resolve_fields_options(o, voxel);
  CHECK(r.indicator.band == 5.0);
  CHECK(r.embedding.sub == 0);  // chosen by build_fields once the thin parts are known
  CHECK(embedding_subcells(o.embedding, 1.0) == 1);
  CHECK(embedding_subcells(o.embedding, 1.0, kMaxThinShareForOneSubcell) == 1);
  CHECK(embedding_subcells(o.embedding, 1.0, 0.05) == 2);  // thin layers
  CHECK(embedding_subcells(o.embedding, 1.0, 0.0, 5.0) == 1);
  CHECK(embedding_subcells(o.embedding, 1.0, 0.0, 4.0) == 2);  // a band given too shallow for one subcell's stencil
  CHECK(resolve_fields_options(r, voxel).indicator.band == 5.0);  // idempotent
  o.embedding.sub = 3;  // given: kept
  o.indicator.band = 6;
  r = resolve_fields_options(o, voxel);
  CHECK(embedding_subcells(r.embedding, 1.0) == 3);
  CHECK(r.indicator.band == 6.0);
  // The closed volume's padding follows the chosen band.
  io::VolumeGeometry g;
  g.spacing = {voxel, voxel, voxel};
  o = FieldsOptions{};
  CHECK(face_padding(o, g) == std::ceil(4.0 + 3.0) + 1);
  o.sizing.h_min = 0.5;
  CHECK(face_padding(o, g) == std::ceil(5.0 + 3.0) + 1);

  // build_fields: a floor of a voxel and no thin parts gives one subcell; thin slabs (layers of 1-3 voxels) keep two.
  {
    FieldsOptions unit;
    unit.sizing.h_min = 1.0;
    const auto ball = test::make_volume(io::SynthShape::sphere, 32, 10.0);
    const auto fb = build_fields(ball.grid, ball.labels.data(), unit);
    CHECK(fb.embedding.sub == 1);
    CHECK(fb.report.thin_share == 0.0);
    const auto slabs = test::make_volume(io::SynthShape::slabs, 24);
    const auto fs = build_fields(slabs.grid, slabs.labels.data(), unit);
    MESSAGE("slabs: thin share " << fs.report.thin_share);
    CHECK(fs.report.thin_share > kMaxThinShareForOneSubcell);
    CHECK(fs.embedding.sub == 2);
    CHECK(fs.fields.band == 5.0);  // the band was chosen before the thin parts were known
    // A band given at 4 voxels keeps two subcells (one would need 5) rather than failing.
    FieldsOptions shallow = unit;
    shallow.indicator.band = 4;
    CHECK(build_fields(ball.grid, ball.labels.data(), shallow).embedding.sub == 2);
    // Thin parts not measured (no tightening, junction correction or island margin): they count as everywhere.
    FieldsOptions unmeasured = unit;
    unmeasured.indicator.tighten_radius = 0;
    unmeasured.indicator.junction_correction = 0;
    unmeasured.indicator.island_margin = 0;
    const auto fu = build_fields(slabs.grid, slabs.labels.data(), unmeasured);
    CHECK(fu.report.thin_share == 1.0);
    CHECK(fu.embedding.sub == 2);
  }

  // At S = 1 the lookups still agree with direct projections (sphere of radius 20 voxels; 0.02 at S = 1/2 above).
  const auto vol = test::make_volume(io::SynthShape::sphere, 56, 20.0);
  EmbeddingOptions one;
  one.sub = 1;
  IndicatorOptions deep;
  deep.band = embedding_indicator_band(one, 1);
  const auto fields = build_indicator_fields(vol.grid, vol.labels.data(), deep);
  const auto E = build_closest_point_embedding(fields, one);
  REQUIRE(E.sub == 1);
  CHECK(E.fine.size() == E.block_count());
  const double worst = worst_lookup_error(vol, fields, E);
  MESSAGE("S = 1: WENO4 lookup vs direct projection: max " << worst << " voxel");
  CHECK(worst < 0.1);
}

TEST_CASE("curvature correction: the smoothed ball keeps its radius") {
  // Two rounds of a sigma = 1 Gaussian shrink a ball of radius R by about 2 / R voxels (0.1 at R = 20); the
  // correction subtracts the smoothed Laplacian term and should leave no systematic offset.
  const auto vol = test::make_volume(io::SynthShape::sphere, 56, 20.0);
  auto mean_radial = [&](bool correct) {
    IndicatorOptions o;
    o.curvature_correction = correct;
    const auto fields = build_indicator_fields(vol.grid, vol.labels.data(), o);
    const auto E = build_closest_point_embedding(fields);
    double sum = 0, worst = 0;
    for (const auto& p : E.fine) {
      const double d = glm::length(glm::dvec3(p) - vol.centre) - 20.0;
      sum += d;
      worst = std::max(worst, std::fabs(d));
    }
    return std::pair{sum / double(E.fine.size()), worst};
  };
  const auto [plain_mean, plain_worst] = mean_radial(false);
  const auto [mean, worst] = mean_radial(true);
  MESSAGE("closest points minus R: mean " << plain_mean << " -> " << mean << ", largest |.| " << plain_worst << " -> "
                                          << worst << " voxel");
  CHECK(plain_mean < -0.07);  // the shrinkage is there without the correction (2 / R = 0.1)
  CHECK(std::fabs(mean) < 0.03);
  CHECK(worst < plain_worst);
}

TEST_CASE("wedge ball: 9 interfaces, 8 triple curves, 4 quadruple points near the analytic ones") {
  const auto wb = test::make_volume(io::SynthShape::wedge_ball, 48);
  const auto fields = build_indicator_fields(wb.grid, wb.labels.data());
  const auto E = build_closest_point_embedding(fields);
  int interfaces = 0, curves = 0, curve_components = 0;
  for (const auto& f : E.features) {
    interfaces += f.kind == FeatureKind::interface;
    curves += f.kind == FeatureKind::triple_curve;
    if (f.kind == FeatureKind::triple_curve) curve_components += int(f.components);
  }
  CHECK(interfaces == 9);
  CHECK(curves == 7);             // material sets: (1,2,3) meets in two separate curves
  CHECK(curve_components == 8);
  // Closest points stored for the triple curves lie on the analytic curves.
  const auto [mean_curve, worst_curve] = curve_errors(wb, fields, E);
  MESSAGE("triple-curve closest points: distance to the analytic curves mean " << mean_curve << ", max " << worst_curve
                                                                              << " voxel");
  // Issue 5 asks for 0.75 voxel at most: measured mean 0.26, max 0.62 here without the curve smoothing (build_fields
  // adds it: 0.24 / 0.55, see its test below; from 40^3 to 128^3 at most 0.72 with it, 0.82 without).
  CHECK(mean_curve < 0.4);
  CHECK(worst_curve < 0.75);
  REQUIRE(E.quadruple_points.size() == 4);
  REQUIRE(wb.junctions.quadruple_points.size() == 4);
  for (const auto& q : wb.junctions.quadruple_points) {
    const glm::dvec3 want(q.position[0], q.position[1], q.position[2]);
    double best = 1e9;
    for (const auto& qp : E.quadruple_points) best = std::min(best, glm::length(qp.position - want));
    MESSAGE("quadruple point error " << best << " voxel");
    CHECK(best < 0.5);  // issue 5 asks for 1 voxel; 0.15 to 0.21 measured
  }
}

TEST_CASE("the embedding does not depend on the thread count") {
  const auto wb = test::make_volume(io::SynthShape::wedge_ball, 40);
  const auto fields = build_indicator_fields(wb.grid, wb.labels.data());
  for (const int sub : {1, 2}) {
    EmbeddingOptions o;
    o.sub = sub;
    IndicatorFields F = fields;
    if (sub == 1) {  // needs the deeper band
      IndicatorOptions io;
      io.band = embedding_indicator_band(o, 1);
      F = build_indicator_fields(wb.grid, wb.labels.data(), io);
    }
    const auto many = build_closest_point_embedding(F, o);
    ClosestPointEmbedding one;
    {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
      one = build_closest_point_embedding(F, o);
    }
    REQUIRE(one.fine.size() == many.fine.size());
    size_t differ = 0;
    for (size_t i = 0; i < one.fine.size(); ++i)
      differ += std::memcmp(&one.fine[i], &many.fine[i], sizeof(glm::vec4)) != 0;
    CHECK_MESSAGE(differ == 0, "subcells " << sub);
    CHECK(one.keys == many.keys);
  }
}

TEST_CASE("wedge ball: the junction correction levels the fields at the triple curves and moves them to the analytic ones") {
  // Smoothing and interpolation lower a field at a material's convex edge, so where a flat side meets two wedge
  // edges (the ball's rim) the flat material grows into the wedges. At 40^3 that leaves curve points 0.83 voxel off.
  const auto wb = test::make_volume(io::SynthShape::wedge_ball, 40);
  IndicatorOptions plain, corrected;  // the default correction against none
  plain.junction_correction = 0;
  REQUIRE(corrected.junction_correction > 0);
  const auto F0 = build_indicator_fields(wb.grid, wb.labels.data(), plain);
  const auto F1 = build_indicator_fields(wb.grid, wb.labels.data(), corrected);
  // On the analytic rim curves (background 0 and two wedges) away from the poles, the three fields should all be 0:
  // the spread (largest minus smallest) measures the pull.
  auto spread = [&](const IndicatorFields& F) {
    double sum = 0;
    size_t n = 0;
    for (const auto& c : wb.junctions.triple_curves) {
      if (c.materials[0] != 0) continue;
      for (size_t i = c.points.size() / 4; i < 3 * c.points.size() / 4; ++i) {
        const glm::dvec3 x(c.points[i][0], c.points[i][1], c.points[i][2]);
        double lo = 1e9, hi = -1e9;
        for (uint16_t label : c.materials) {
          const size_t m = size_t(std::find(F.labels.begin(), F.labels.end(), label) - F.labels.begin());
          const double v = F.fields[m].sample_cubic_local(x);
          lo = std::min(lo, v);
          hi = std::max(hi, v);
        }
        sum += hi - lo;
        ++n;
      }
    }
    return sum / double(n);
  };
  const double s0 = spread(F0), s1 = spread(F1);
  const auto [mean0, max0] = curve_errors(wb, F0, build_closest_point_embedding(F0));
  const auto [mean1, max1] = curve_errors(wb, F1, build_closest_point_embedding(F1));
  MESSAGE("field spread on the rim curves " << s0 << " -> " << s1 << " voxel; curve points mean " << mean0 << " -> "
                                            << mean1 << ", max " << max0 << " -> " << max1 << " voxel");
  CHECK(s1 < 0.8 * s0);  // measured 0.49 -> 0.36 at the default 0.4 (0.48 -> 0.32 at 0.6, before the curvature correction)
  CHECK(mean1 < 0.9 * mean0);  // measured 0.31 -> 0.26
  CHECK(max1 < 0.75);     // measured 0.83 -> 0.72
  CHECK(max1 < max0);
}

TEST_CASE("curve smoothing: the wedge ball's curves move towards the analytic ones, the fields away from them stay") {
  const auto wb = test::make_volume(io::SynthShape::wedge_ball, 48);
  const auto F0 = build_indicator_fields(wb.grid, wb.labels.data());
  auto F1 = F0;
  const auto moves = triple_curve_moves(F0);
  const auto done = smooth_triple_curves(F1);
  REQUIRE(done.curve_points == moves.size());
  CHECK(done.moved_points > done.curve_points / 2);
  CHECK(done.largest_move <= 1.5 + 1e-9);  // at most a voxel of extrapolation and half a voxel of fit
  EmbeddingOptions fit_only;
  fit_only.junction_extrapolation = false;
  auto F_fit = F0;
  CHECK(smooth_triple_curves(F_fit, fit_only).largest_move <= 0.5 + 1e-9);  // larger fit moves are refused
  CHECK(done.changed_values > 0);
  const auto E0 = build_closest_point_embedding(F0), E1 = build_closest_point_embedding(F1);
  const auto [mean0, max0] = curve_errors(wb, F0, E0);
  const auto [mean1, max1] = curve_errors(wb, F1, E1);
  MESSAGE(done.moved_points << " of " << done.curve_points << " curve points moved, by " << done.largest_move
                            << " voxel at most; curve points to the analytic curves: mean " << mean0 << " -> " << mean1
                            << ", max " << max0 << " -> " << max1 << " voxel");
  CHECK(mean1 < mean0 - 0.05);  // measured 0.256 -> 0.182 (0.239 without the T-junction extrapolation)
  CHECK(max1 < max0 - 0.03);    // measured 0.618 -> 0.548 (the same without it)
  // The quadruple points end the curves and stay where they were.
  REQUIRE(E1.quadruple_points.size() == E0.quadruple_points.size());
  for (size_t q = 0; q < E0.quadruple_points.size(); ++q)
    CHECK(glm::length(E1.quadruple_points[q].position - E0.quadruple_points[q].position) < 0.1);
  // Beyond 3.5 voxels of every curve point the fields are unchanged.
  std::vector<uint8_t> near(wb.grid.voxel_count(), 0);
  for (const auto& m : moves) {
    const glm::ivec3 c = glm::ivec3(glm::round(m.position / wb.grid.spacing));
    for (int z = -4; z <= 4; ++z)
      for (int y = -4; y <= 4; ++y)
        for (int x = -4; x <= 4; ++x) {
          const glm::ivec3 v = c + glm::ivec3(x, y, z);
          if (wb.grid.inside(v.x, v.y, v.z)) near[wb.grid.index(v.x, v.y, v.z)] = 1;
        }
  }
  size_t far = 0, differ = 0;
  for (size_t v = 0; v < near.size(); ++v) {
    if (near[v]) continue;
    ++far;
    const glm::ivec3 c = wb.grid.voxel(v);
    for (size_t m = 0; m < F0.fields.size(); ++m) differ += F0.fields[m].at(c.x, c.y, c.z) != F1.fields[m].at(c.x, c.y, c.z);
  }
  CHECK(far > near.size() / 2);
  CHECK(differ == 0);
  // Off: nothing moves.
  EmbeddingOptions off;
  off.curve_smoothing = 0;
  auto F2 = F0;
  CHECK(smooth_triple_curves(F2, off).changed_values == 0);
}

TEST_CASE("T-junction extrapolation: rim and inner-ball curves move onto the extended interfaces, the Y-junction axis does not") {
  // The wedge ball's rim curves are T-junctions (a wedge plane ends on the ball's flat-looking surface), and so are the
  // inner-ball curves (a plane ends on a ball of radius 6.75 voxels, whose two sides' mean directions are only
  // 128-139 degrees apart); the axis where the three wedges meet at 120 degrees is a Y-junction and gets no
  // extrapolation, so away from the quadruple points its moves are those of the fit alone.
  const auto wb = test::make_volume(io::SynthShape::wedge_ball, 48);
  const auto F = build_indicator_fields(wb.grid, wb.labels.data());
  EmbeddingOptions fit_only;
  fit_only.junction_extrapolation = false;
  const auto with = triple_curve_moves(F), without = triple_curve_moves(F, fit_only);
  REQUIRE(with.size() == without.size());
  auto nearest_curve = [&](const glm::dvec3& p) {
    const io::TripleCurve* best = nullptr;
    double best_d = std::numeric_limits<double>::infinity();
    for (const auto& c : wb.junctions.triple_curves) {
      const double d = test::distance_to_curve(wb.junctions, c.materials, p);
      if (d < best_d) best_d = d, best = &c;
    }
    return best;
  };
  auto to_quadruple_point = [&](const glm::dvec3& p) {
    double d = std::numeric_limits<double>::infinity();
    for (const auto& q : wb.junctions.quadruple_points)
      d = std::min(d, glm::length(p - glm::dvec3(q.position[0], q.position[1], q.position[2])));
    return d;
  };
  struct Error {
    double with = 0, without = 0, worst_with = 0, worst_without = 0;
    size_t count = 0;
  } rim, inner;
  double axis_difference = 0, axis_difference_near = 0;
  size_t axis = 0;
  for (size_t i = 0; i < with.size(); ++i) {
    REQUIRE(glm::length(with[i].position - without[i].position) == 0.0);  // the same curve points, in one order
    const auto* curve = nearest_curve(with[i].position);
    REQUIRE(curve);
    const auto& m = curve->materials;
    if (m == std::array<uint16_t, 3>{1, 2, 3}) {
      double& largest = to_quadruple_point(with[i].position) > 6.0 ? axis_difference : axis_difference_near;
      largest = std::max(largest, glm::length(with[i].move - without[i].move));
      ++axis;
    } else {
      Error& e = m[0] == 0 ? rim : inner;
      const double dw = test::distance_to_curve(wb.junctions, m, with[i].position + with[i].move);
      const double dn = test::distance_to_curve(wb.junctions, m, without[i].position + without[i].move);
      e.with += dw, e.without += dn;
      e.worst_with = std::max(e.worst_with, dw), e.worst_without = std::max(e.worst_without, dn);
      ++e.count;
    }
  }
  for (const auto* e : {&rim, &inner})
    MESSAGE(std::string(e == &rim ? "rim" : "inner-ball") << " curves, " << e->count << " points to the analytic curves: mean "
                                              << e->without / double(e->count) << " -> " << e->with / double(e->count)
                                              << ", max " << e->worst_without << " -> " << e->worst_with);
  MESSAGE(axis << " axis points, largest difference " << axis_difference << " beyond 6 voxels of the quadruple points, "
               << axis_difference_near << " within");
  REQUIRE(rim.count > 100);
  REQUIRE(inner.count > 50);
  REQUIRE(axis > 20);
  // No axis point passes as a T-junction; near the quadruple points the fit sees moved points of other curves.
  CHECK(axis_difference == 0.0);
  CHECK(axis_difference_near < 0.01);  // measured 0.0005
  CHECK(rim.with < 0.7 * rim.without);                   // measured 0.223 -> 0.122
  CHECK(rim.worst_with < rim.worst_without - 0.05);      // measured 0.477 -> 0.394
  CHECK(inner.with < 0.8 * inner.without);               // measured 0.298 -> 0.192
  CHECK(inner.worst_with < inner.worst_without - 0.05);  // measured 0.502 -> 0.399
}

TEST_CASE("junction correction: no offsets where thin layers make the junctions") {
  // The concentric shells have no real junctions, but the staircase of their 1- and 1.5-voxel layers lets the
  // neighbours on either side touch at voxel corners. An offset there cut the layers (15 interfaces, none manifold
  // on the 40^3 shells), so corners among thin parts get none: the fields equal those without the correction.
  const auto v = test::make_volume(io::SynthShape::shells, 40);
  IndicatorOptions off, on;
  off.junction_correction = 0;
  REQUIRE(on.junction_correction > 0);
  const auto F0 = build_indicator_fields(v.grid, v.labels.data(), off);
  const auto F1 = build_indicator_fields(v.grid, v.labels.data(), on);
  REQUIRE(F0.fields.size() == F1.fields.size());
  double largest = 0;
  for (size_t m = 0; m < F0.fields.size(); ++m)
    for (int k = 0; k < v.grid.dims.z; ++k)
      for (int j = 0; j < v.grid.dims.y; ++j)
        for (int i = 0; i < v.grid.dims.x; ++i)
          largest = std::max(largest, double(std::fabs(F1.fields[m].at(i, j, k) - F0.fields[m].at(i, j, k))));
  CHECK(largest == 0.0);
  // ... while the wedge ball's real junctions do get them (the test above measures their effect).
  const auto wb = test::make_volume(io::SynthShape::wedge_ball, 40);
  const auto W = build_indicator_fields(wb.grid, wb.labels.data(), on);
  double moved = 0;
  for (const auto& o : W.junction_offsets)
    for (int k = 0; k < wb.grid.dims.z; ++k)
      for (int j = 0; j < wb.grid.dims.y; ++j)
        for (int i = 0; i < wb.grid.dims.x; ++i) moved = std::max(moved, double(std::fabs(o.at(i, j, k))));
  CHECK(moved > 0.1);
}

TEST_CASE("embedding bands stay near where their materials meet: none across a thin layer that separates them") {
  // Materials 1 (below) and 2 (above) separated by a 2-voxel layer of 3, except through a hole of radius 3 around
  // (10, 10), where 1 and 2 touch, in a 56 x 56 layer. Every voxel of the layer is within reach of both 1 and 2, but
  // their interface exists only at the hole: its band must not fill the layer (Newton failed at every fine point
  // there).
  const io::LabelVolume v = test::label_volume(56, 56, 20, [](int i, int j, int k) {
    const bool hole = (i - 10.2) * (i - 10.2) + (j - 9.7) * (j - 9.7) < 9;
    return k < 9 ? 1 : k >= 11 ? 2 : hole ? (k < 10 ? 1 : 2) : 3;
  });
  const Grid grid = grid_of(v);
  const auto F = build_indicator_fields(grid, v.labels.data(), IndicatorOptions{});
  const auto E = build_closest_point_embedding(F, EmbeddingOptions{});
  const int f12 = E.feature_index(FeatureKind::interface, {0, 1, 0xffff, 0xffff});  // labels 1, 2 -> indices 0, 1
  REQUIRE(f12 >= 0);
  size_t blocks = 0, far = 0, layer = 0;
  for (size_t slot = 0; slot < E.keys.size(); ++slot) {
    if (E.keys[slot] == ClosestPointEmbedding::kEmpty) continue;
    const glm::ivec3 c = grid.voxel(size_t(E.keys[slot] >> 16));
    if (int(E.keys[slot] & 0xffff) == f12) {
      ++blocks;
      // The hole's voxels reach x, y = 13; bands extend 2 reach + 1 voxel (7.7) rounded up to 4-voxel bins.
      far += std::max(c.x, c.y) > 28;
    } else if (E.features[E.keys[slot] & 0xffff].kind == FeatureKind::interface) {
      ++layer;
    }
  }
  MESSAGE(blocks, " blocks of the 1/2 interface, ", far, " far from the hole; ", layer, " of the others");
  CHECK(blocks > 0);
  CHECK(far == 0);
  CHECK(layer > 10 * blocks / 4);  // the layer's own interfaces keep their whole bands
}

// Materials 1 | 2 | 3 in layers across the diagonal: 2 where i + j + k is 29 or 30, so 2x2x2 groups with sums 28-31
// hold all three labels and step 1 finds the triple curve 1/2/3 all along the layer. The smooth fields keep layer 2
// whole (it is 1.15 voxels thick), so that curve does not exist and Newton fails at every fine point of its band.
struct DiagonalLayers {
  io::LabelVolume v = test::label_volume(24, 24, 24, [](int i, int j, int k) {
    const int s = i + j + k;
    return s < 29 ? 1 : s <= 30 ? 2 : 3;
  });
  IndicatorFields F = build_indicator_fields(grid_of(v), v.labels.data(), IndicatorOptions{});
  ClosestPointEmbedding E = build_closest_point_embedding(F, EmbeddingOptions{});
  int curve = E.feature_index(FeatureKind::triple_curve, {0, 1, 2, 0xffff});
};

TEST_CASE("curve smoothing: a triple curve that meets only in the labels gives no curve points") {
  // DiagonalLayers: the curve smoothing must measure no points there (it measured 15,603, all on no curve, before its embedding
  // dropped the blocks where no point landed).
  const DiagonalLayers layers;
  const auto& F = layers.F;
  const auto& E = layers.E;
  const int curve = layers.curve;
  REQUIRE(curve >= 0);  // found in the labels
  size_t curve_blocks = 0, landed = 0;
  for (size_t slot = 0; slot < E.keys.size(); ++slot) {
    if (E.keys[slot] == ClosestPointEmbedding::kEmpty || int(E.keys[slot] & 0xffff) != curve) continue;
    ++curve_blocks;
    for (int q = 0; q < 8; ++q) {
      const glm::dvec3 cp(glm::vec3(E.fine[size_t(E.blocks[slot]) * 8 + size_t(q)]));
      double lo = 1e300, hi = -1e300;
      for (int m = 0; m < 3; ++m) {
        const double value = F.fields[size_t(m)].sample_cubic_local(cp);
        lo = std::min(lo, value);
        hi = std::max(hi, value);
      }
      landed += hi - lo < 1e-3;
    }
  }
  const auto moves = triple_curve_moves(F, EmbeddingOptions{});
  MESSAGE(curve_blocks, " blocks of the curve in the full embedding, ", landed, " points on it; ", moves.size(),
          " curve points measured by the smoothing");
  CHECK(curve_blocks > 0);  // the full embedding keeps them (closest_point_embedding.cpp, step 5)
  CHECK(landed == 0);       // the curve is not in the fields
  CHECK(moves.empty());
}

TEST_CASE("embedding stats: points with no closest point are counted, and their blocks give up early after the first") {
  // DiagonalLayers: Newton fails at every fine point of the 1/2/3 curve's band. Each such point tries
  // seven starts of up to two 30-step runs (420 steps). A block's later points start where the point before it stopped;
  // once that one failed, all but their last start give up when Newton stagnates (only the last start's run decides
  // where a failed point stays). Before that, the failed points averaged 408 steps here, now 163.
  const DiagonalLayers layers;
  const auto& E = layers.E;
  const int curve = layers.curve;
  REQUIRE(curve >= 0);
  size_t curve_points = 0;
  for (size_t slot = 0; slot < E.keys.size(); ++slot)
    if (E.keys[slot] != ClosestPointEmbedding::kEmpty && int(E.keys[slot] & 0xffff) == curve)
      curve_points += size_t(E.sub * E.sub * E.sub);
  const auto& s = E.stats;
  MESSAGE(s.fine_points, " fine points, ", s.failed_points, " failed (", curve_points, " on the curve's blocks), ",
          s.newton_steps, " Newton steps");
  CHECK(s.fine_points == E.fine.size());
  CHECK(s.failed_points >= curve_points);
  CHECK(s.failed_points < s.fine_points);  // the layers' own interfaces are found
  // Landed points take a few steps each (about 2 here); the failed ones dominate.
  CHECK(double(s.newton_steps) / double(s.failed_points) < 250.0);

  // A sphere: every point lands.
  const auto ball = test::make_volume(io::SynthShape::sphere, 32);
  const auto FB = build_indicator_fields(ball.grid, ball.labels.data(), IndicatorOptions{});
  const auto EB = build_closest_point_embedding(FB, EmbeddingOptions{});
  CHECK(EB.stats.fine_points == EB.fine.size());
  CHECK(EB.stats.failed_points == 0);
  CHECK(EB.stats.newton_steps > 0);
  CHECK(double(EB.stats.newton_steps) / double(EB.stats.fine_points) < 10.0);
}

TEST_CASE("embedding tiles: every (cell, feature) finds the embedding's own block, and no other cell finds one") {
  // A grid that is not a multiple of the tile size, so edge tiles are partial.
  const auto wb = test::make_volume(io::SynthShape::wedge_ball, 34);
  const auto fields = build_indicator_fields(wb.grid, wb.labels.data());
  const auto E = build_closest_point_embedding(fields);
  const auto T = build_embedding_tiles(E);
  CHECK(T.dims == (E.grid.dims + 3) / 4);
  size_t found = 0, mismatches = 0;
  for (uint32_t f = 0; f < E.features.size(); ++f)
    for (int z = 0; z < E.grid.dims.z; ++z)
      for (int y = 0; y < E.grid.dims.y; ++y)
        for (int x = 0; x < E.grid.dims.x; ++x) {
          const int64_t want = E.find_block(E.grid.index(x, y, z), f);
          mismatches += T.find_block({x, y, z}, f) != want;
          found += want >= 0;
        }
  CHECK(found == E.block_count());
  CHECK(mismatches == 0);
  // Each tile record holds at least one block; records are 64 cells each.
  const size_t records = T.cells.size() / EmbeddingTiles::kCells;
  CHECK(T.cells.size() == records * EmbeddingTiles::kCells);
  for (size_t r = 0; r < records; ++r)
    CHECK(std::any_of(T.cells.begin() + ptrdiff_t(r * 64), T.cells.begin() + ptrdiff_t(r * 64 + 64),
                      [](uint32_t b) { return b != EmbeddingTiles::kNoBlock; }));
  MESSAGE(E.block_count() << " blocks in " << records << " tiles; index " << T.memory_bytes() / 1024
                          << " KiB against the cell table's " << (E.keys.size() * 12) / 1024 << " KiB");
  // An empty embedding gives an empty index that finds nothing.
  ClosestPointEmbedding empty;
  empty.grid = E.grid;
  const auto none = build_embedding_tiles(empty);
  CHECK(none.cells.empty());
  CHECK(none.find_block({1, 2, 3}, 0) == -1);
}

TEST_CASE("check_blocks sees the embedding's block count before its fine points, in the curve pass and again after") {
  // The curve smoothing's pass counts every feature's blocks while it projects only the curves'; both counts come
  // before any fine point is projected, so a hook that throws stops the fields there.
  const auto wb = test::make_volume(io::SynthShape::wedge_ball, 32);
  FieldsOptions o;
  std::vector<std::pair<size_t, int>> calls;
  o.embedding.check_blocks = [&](size_t blocks, int sub) { calls.push_back({blocks, sub}); };
  const auto r = build_fields(wb.grid, wb.labels.data(), o);
  REQUIRE(calls.size() == 2);
  CHECK(calls[1].first == r.embedding.block_count());
  CHECK(calls[1].second == r.embedding.sub);
  CHECK(calls[0].second == r.embedding.sub);
  // The fields differ between the passes only by the curves' warp (fractions of a voxel): counts within 2%.
  CHECK(std::fabs(double(calls[0].first) - double(calls[1].first)) <= 0.02 * double(calls[1].first));
  FieldsOptions refusing;
  refusing.embedding.check_blocks = [](size_t blocks, int) {
    throw std::runtime_error("refused at " + std::to_string(blocks) + " blocks");
  };
  const auto start = std::chrono::steady_clock::now();
  CHECK_THROWS_WITH_AS(build_fields(wb.grid, wb.labels.data(), refusing), doctest::Contains("refused at"),
                       std::runtime_error);
  MESSAGE("refused after " << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()
                           << " s; the whole fields took " << r.report.embedding_seconds << " s of embedding");
}

namespace {

// Label 2, one voxel thick and stepping across x like a falx (x = round(15 + 1.5 sin(y / 5))), inside label 1 and
// ending on a one-voxel layer of 3 under 4 (the CSF under the skull).
int falx_x(int j) { return int(std::lround(15 + 1.5 * std::sin(j / 5.0))); }
struct FalxEmbedding {
  Grid grid;
  ClosestPointEmbedding E;
};
// The volume's embedding at default settings, built once for the tests that read it.
const FalxEmbedding& falx_embedding() {
  static const FalxEmbedding built = [] {
    const io::LabelVolume v = test::label_volume(
        32, 32, 20, [&](int i, int j, int k) { return k > 14 ? 4 : k == 14 ? 3 : i == falx_x(j) ? 2 : 1; });
    const Grid grid = grid_of(v);
    const auto F = build_indicator_fields(grid, v.labels.data(), IndicatorOptions{});
    return FalxEmbedding{grid, build_closest_point_embedding(F, EmbeddingOptions{})};
  }();
  return built;
}

// Calls fn(x, cp) for every fine point x (voxel-index coordinates) of the feature's blocks and its closest point cp.
template <class Fn>
void for_each_fine_point(const ClosestPointEmbedding& E, const Grid& grid, int feature, Fn fn) {
  const int sub = E.sub, per_block = sub * sub * sub;
  for (size_t slot = 0; slot < E.keys.size(); ++slot) {
    if (E.keys[slot] == ClosestPointEmbedding::kEmpty || int(E.keys[slot] & 0xffff) != feature) continue;
    const glm::ivec3 c = grid.voxel(size_t(E.keys[slot] >> 16));
    for (int q = 0; q < per_block; ++q) {
      const glm::dvec3 x = glm::dvec3(c) + glm::dvec3(q % sub, (q / sub) % sub, q / (sub * sub)) / double(sub);
      fn(x, glm::dvec3(glm::vec3(E.fine[size_t(E.blocks[slot]) * size_t(per_block) + size_t(q)])));
    }
  }
}

}  // namespace

TEST_CASE("a one-voxel sheet keeps closest points on both of its sides") {
  // A block's fine points lie on both sides of the sheet and inside it; each must find the nearer of the sheet's two
  // sides. A projection started from the block's previous closest point keeps that point's side: 325 of the 8056
  // points on the sheet's +x side and within it took a point on its -x side, a voxel away instead of a twentieth.
  const auto& [grid, E] = falx_embedding();
  const int f12 = E.feature_index(FeatureKind::interface, {0, 1, 0xffff, 0xffff});
  REQUIRE(f12 >= 0);
  // Per side: fine points on or beyond a face of the sheet's voxels (rows clear of its steps and of the layer of 3),
  // and those whose closest point is on the other side.
  size_t beside[2] = {0, 0}, across[2] = {0, 0};
  for_each_fine_point(E, grid, f12, [&](const glm::dvec3& x, const glm::dvec3& cp) {
    const double centre = falx_x(int(std::lround(x.y)));
    const double off = x.x - centre;
    if (std::abs(off) < 0.5 || std::abs(x.y - std::round(x.y)) > 0.3 || x.z > 13.5) return;
    const int side = off > 0;
    ++beside[side];
    across[side] += (cp.x - centre) * off < 0 && std::abs(cp.x - centre) > 0.05;
  });
  MESSAGE("fine points on the sheet's faces and beyond, per side: ", beside[0], " / ", beside[1], ", closest point across it: ", across[0], " / ",
          across[1]);
  REQUIRE(beside[0] > 100);
  REQUIRE(beside[1] > 100);
  CHECK(across[0] <= beside[0] / 100);
  CHECK(across[1] <= beside[1] / 100);
}

TEST_CASE("the two triple curves where a one-voxel sheet ends on a layer both keep their closest points") {
  // Where the sheet of falx_embedding's volume meets the layer of 3, labels 1, 2 and 3 meet along two curves a voxel
  // apart, one on each side of the sheet: one feature. A fine point beside one curve must find that one. Started from the
  // block's previous closest point, 115 of the 1988 points counted on the sheet's +x side took the curve on its -x
  // side; none does with the nearer projection tried at every curve point (52 where the linearized distance chose).
  const auto& [grid, E] = falx_embedding();
  const int curve = E.feature_index(FeatureKind::triple_curve, {0, 1, 2, 0xffff});
  REQUIRE(curve >= 0);
  // Per side: fine points at least half a voxel beside the sheet's centre and within a voxel of the layer's lower
  // face (rows clear of its steps), and those whose closest point lies on the other side of the centre. (Farther
  // out the two curves are nearly as far: 3 voxels below the layer, 3.0 against 3.16.)
  size_t beside[2] = {0, 0}, across[2] = {0, 0};
  for_each_fine_point(E, grid, curve, [&](const glm::dvec3& x, const glm::dvec3& cp) {
    const int row = int(std::lround(x.y));
    if (falx_x(row - 1) != falx_x(row) || falx_x(row + 1) != falx_x(row)) return;
    const double centre = falx_x(row), off = x.x - centre;
    if (std::abs(off) < 0.5 || std::abs(x.z - 13.5) > 1.0) return;
    const int side = off > 0;
    ++beside[side];
    across[side] += (cp.x - centre) * off < 0;
  });
  MESSAGE("fine points beside the sheet's end, per side: ", beside[0], " / ", beside[1], ", closest point on the other curve: ",
          across[0], " / ", across[1]);
  REQUIRE(beside[0] > 100);
  REQUIRE(beside[1] > 100);
  CHECK(across[0] <= beside[0] / 100);
  CHECK(across[1] <= beside[1] / 100);
}

TEST_CASE("the lookup at a closest point beside a one-voxel sheet returns that point") {
  // A point on the feature is its own closest point. Where the two sides of a sheet (or the two triple curves at its
  // end) lie within the lookup's 4^3 stencil, the stencil holds closest points on both, and the WENO4 blend of them
  // returns a point between the two, off the feature: a particle reprojected there drifts across to the other side
  // over a few steps, and that side loses its particles. The stored closest points are the test points; the sheet's
  // points within a voxel of the layer are left out (its end: the closest point map kinks at the curves).
  // Lookups off by more than 0.05 voxel with WENO4 alone: 3,070 of 26,602 on the sheet, 2,781 of 12,325 on the curves
  // (whose fine points then took the retry only where the linearized distance asked for it); with the nearest of WENO4
  // and the one-sided quadratics, 1,836 and 99. (The sheet's rest: where the jump between its sides falls between the
  // two middle samples of a line, every quadratic holds it.)
  const auto& [grid, E] = falx_embedding();
  const int per_block = E.sub * E.sub * E.sub;
  for (const auto& [kind, materials] :
       {std::pair{FeatureKind::interface, std::array<uint16_t, 4>{0, 1, 0xffff, 0xffff}},
        std::pair{FeatureKind::triple_curve, std::array<uint16_t, 4>{0, 1, 2, 0xffff}}}) {
    const int feature = E.feature_index(kind, materials);
    REQUIRE(feature >= 0);
    size_t looked_up = 0, off = 0;
    for (size_t slot = 0; slot < E.keys.size(); ++slot) {
      if (E.keys[slot] == ClosestPointEmbedding::kEmpty || int(E.keys[slot] & 0xffff) != feature) continue;
      for (int q = 0; q < per_block; ++q) {
        const glm::vec3 cp = glm::vec3(E.fine[size_t(E.blocks[slot]) * size_t(per_block) + size_t(q)]);
        if (kind == FeatureKind::interface && cp.z > 12.5f) continue;
        const auto found = ref::cp_lookup(E, cp, uint32_t(feature));
        if (!found.valid) continue;
        ++looked_up;
        off += glm::length(glm::vec3(found.value) - cp) > 0.05f * float(grid.min_spacing());
      }
    }
    const std::string name = kind == FeatureKind::interface ? "sheet" : "curves";
    MESSAGE(name, ": ", off, " of ", looked_up, " closest points looked up more than 0.05 voxel away");
    REQUIRE(looked_up > 10000);
    CHECK(off <= looked_up / (kind == FeatureKind::interface ? 12 : 50));
  }
}
