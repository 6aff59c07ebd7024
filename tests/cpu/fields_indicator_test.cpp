// Distance transform and per-material indicator fields on analytic volumes (sphere, slabs with a one-voxel layer).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "fields/distance_transform.h"
#include "fields/indicator_fields.h"
#include "fields_volumes.h"

using namespace cpmesh::fields;

namespace {

// Zero of f(t) on [a, b] by bisection, f(a) and f(b) of opposite signs.
template <class F>
double bisect(F f, double a, double b) {
  double fa = f(a);
  for (int it = 0; it < 60; ++it) {
    const double m = 0.5 * (a + b), fm = f(m);
    if ((fm < 0) == (fa < 0)) {
      a = m;
      fa = fm;
    } else {
      b = m;
    }
  }
  return 0.5 * (a + b);
}

}  // namespace

TEST_CASE("squared distance transform matches brute force, anisotropic spacing") {
  Grid g{{13, 7, 9}, {1.0, 0.7, 1.3}, {0, 0, 0}};
  std::mt19937 rng(4);
  std::vector<float> f(g.voxel_count(), std::numeric_limits<float>::infinity());
  std::vector<glm::dvec3> seeds;
  for (int k = 0; k < g.dims.z; ++k)
    for (int j = 0; j < g.dims.y; ++j)
      for (int i = 0; i < g.dims.x; ++i)
        if (rng() % 20 == 0) {
          f[g.index(i, j, k)] = 0;
          seeds.push_back(g.local(glm::dvec3(i, j, k)));
        }
  REQUIRE(seeds.size() > 5);
  squared_distance_transform(g, f);
  for (int k = 0; k < g.dims.z; ++k)
    for (int j = 0; j < g.dims.y; ++j)
      for (int i = 0; i < g.dims.x; ++i) {
        double best = 1e300;
        for (const auto& s : seeds) {
          const glm::dvec3 d = g.local(glm::dvec3(i, j, k)) - s;
          best = std::min(best, glm::dot(d, d));
        }
        CHECK(f[g.index(i, j, k)] == doctest::Approx(best).epsilon(1e-5));
      }

  // With a cap: exact within it (the same floats as without), above cap^2 (or infinite) beyond it.
  const double cap = 1.1;  // seeds, and their x and y neighbours
  std::vector<float> capped(g.voxel_count(), std::numeric_limits<float>::infinity());
  for (size_t v = 0; v < capped.size(); ++v)
    if (f[v] == 0) capped[v] = 0;
  squared_distance_transform(g, capped, cap);
  size_t within = 0, beyond = 0, dropped = 0;
  for (size_t v = 0; v < capped.size(); ++v) {
    if (f[v] <= cap * cap) {
      ++within;
      CHECK(capped[v] == f[v]);
    } else {
      ++beyond;
      dropped += std::isinf(capped[v]);
      CHECK(capped[v] > cap * cap);
    }
  }
  CHECK(within > 50);
  CHECK(beyond > 50);
  CHECK(dropped > 0);  // the cap did drop samples

  std::vector<float> none(g.voxel_count(), std::numeric_limits<float>::infinity());
  squared_distance_transform(g, none);
  CHECK(std::isinf(none[17]));
  std::vector<float> all(g.voxel_count(), 0.0f);
  squared_distance_transform(g, all);
  CHECK(all[17] == 0.0f);
}

TEST_CASE("Gaussian pass: every sample is the plain clamped convolution, plateaus and lone constant lines included") {
  // A band between plateaus (the clamped distances the fields blur), noisy inside, and x lines that are constant
  // while their neighbours are not (the passes along y and z take 8 x lines at once). x is no multiple of 8.
  const glm::ivec3 n(37, 19, 23);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> noise(-0.3f, 0.3f);
  std::vector<float> start(size_t(n.x) * size_t(n.y) * size_t(n.z));
  for (int k = 0; k < n.z; ++k)
    for (int j = 0; j < n.y; ++j)
      for (int i = 0; i < n.x; ++i) {
        const double d = std::sqrt(double((i - 15) * (i - 15) + (j - 9) * (j - 9) + (k - 11) * (k - 11))) - 7.0;
        float v = float(std::clamp(d, -3.0, 3.0));
        if (std::fabs(d) < 3.0) v += noise(rng);
        if (j == 4 && k % 3 == 0) v = 3.0f;  // a constant x line among varying ones
        start[(size_t(k) * size_t(n.y) + size_t(j)) * size_t(n.x) + size_t(i)] = v;
      }
  for (double sigma : {0.7, 1.0, 1.6}) {
    const int radius = int(std::ceil(3.0 * sigma));
    std::vector<double> w(size_t(2 * radius + 1));
    double total = 0;
    for (int r = -radius; r <= radius; ++r) total += w[size_t(r + radius)] = std::exp(-0.5 * r * r / (sigma * sigma));
    for (auto& x : w) x /= total;
    for (int axis = 0; axis < 3; ++axis) {
      CAPTURE(sigma);
      CAPTURE(axis);
      std::vector<float> got = start;
      gaussian_pass(got, n, axis, sigma);
      const size_t stride = axis == 0 ? 1 : axis == 1 ? size_t(n.x) : size_t(n.x) * size_t(n.y);
      size_t wrong = 0, plateau = 0, changed = 0;
      for (int k = 0; k < n.z; ++k)
        for (int j = 0; j < n.y; ++j)
          for (int i = 0; i < n.x; ++i) {
            const glm::ivec3 p(i, j, k);
            const size_t at = (size_t(k) * size_t(n.y) + size_t(j)) * size_t(n.x) + size_t(i);
            double acc = 0;
            bool flat = true;
            for (int r = -radius; r <= radius; ++r) {
              const int q = std::clamp(p[axis] + r, 0, n[axis] - 1);
              const float v = start[at - size_t(p[axis]) * stride + size_t(q) * stride];
              acc += w[size_t(r + radius)] * v;
              flat = flat && v == start[at];
            }
            wrong += got[at] != float(acc);
            plateau += flat;
            changed += got[at] != start[at];
          }
      CHECK(wrong == 0);
      CHECK(plateau > start.size() / 4);  // the case has whole windows on one value ...
      CHECK(changed > start.size() / 10);  // ... and windows across the band
    }
  }
}

TEST_CASE("sphere R = 20: the interface lies within 0.5 voxel of the true sphere and labels are kept") {
  const auto vol = cpmesh::test::make_volume(cpmesh::io::SynthShape::sphere, 56, 20.0);
  const Grid& g = vol.grid;
  const glm::dvec3 c = vol.centre;
  const double R = 20.0;
  const auto& labels = vol.labels;
  const auto fields = build_indicator_fields(g, labels.data());
  REQUIRE(fields.labels == std::vector<uint16_t>{0, 1});
  // argmax at every voxel centre is that voxel's label.
  size_t wrong = 0;
  for (int k = 0; k < g.dims.z; ++k)
    for (int j = 0; j < g.dims.y; ++j)
      for (int i = 0; i < g.dims.x; ++i)
        wrong += fields.labels[size_t(fields.material_at(glm::dvec3(i, j, k)))] != labels[g.index(i, j, k)];
  CHECK(wrong == 0);
  // Along rays from the centre, the zero of f1 - f0 (Catmull-Rom) is within 0.5 voxel of R.
  std::mt19937 rng(7);
  std::normal_distribution<double> n01;
  double worst = 0, mean = 0;
  const int rays = 300;
  for (int r = 0; r < rays; ++r) {
    const glm::dvec3 dir = glm::normalize(glm::dvec3(n01(rng), n01(rng), n01(rng)));
    auto g_of = [&](double t) {
      const glm::dvec3 p = c + t * dir;
      return fields.fields[1].sample_cubic(p) - fields.fields[0].sample_cubic(p);
    };
    const double t = bisect(g_of, R - 3, R + 3);
    worst = std::max(worst, std::fabs(t - R));
    mean += std::fabs(t - R) / rays;
  }
  MESSAGE("sphere interface error: mean " << mean << " voxel, max " << worst << " voxel");
  CHECK(worst < 0.5);
  CHECK(mean < 0.2);
  // f is distance-like near the interface: |grad f| close to 1 on the sphere.
  glm::dvec3 grad;
  fields.fields[1].sample_cubic(c + glm::dvec3(R, 0, 0), &grad);
  CHECK(glm::length(grad) == doctest::Approx(1.0).epsilon(0.15));
}

TEST_CASE("fields are stored in a narrow band: memory grows with the surface, not the volume") {
  const auto vol = cpmesh::test::make_volume(cpmesh::io::SynthShape::sphere, 128, 20.0);
  const Grid& g = vol.grid;
  const auto& labels = vol.labels;
  const auto fields = build_indicator_fields(g, labels.data());
  const double dense = 2.0 * double(g.voxel_count()) * sizeof(float);
  MESSAGE("sparse " << fields.memory_bytes() << " bytes vs dense " << dense);
  CHECK(double(fields.memory_bytes()) < 0.15 * dense);
}

TEST_CASE("a layer one voxel thick and a single-voxel component survive") {
  Grid g{{20, 20, 24}, {1, 1, 1}, {0, 0, 0}};
  std::vector<uint16_t> labels(g.voxel_count());
  for (int k = 0; k < g.dims.z; ++k)
    for (int j = 0; j < g.dims.y; ++j)
      for (int i = 0; i < g.dims.x; ++i) labels[g.index(i, j, k)] = k < 10 ? 0 : (k == 10 ? 2 : 1);
  labels[g.index(5, 5, 4)] = 3;  // an isolated voxel
  IndicatorOptions options;
  options.tighten_radius = 3.0;  // far thicker than the layer: it must be protected, not tightened away
  const auto fields = build_indicator_fields(g, labels.data(), options);
  REQUIRE(fields.labels == std::vector<uint16_t>{0, 1, 2, 3});
  CHECK(fields.protected_voxels >= 20u * 20u + 1u);
  CHECK(fields.tightened_voxels == std::vector<uint64_t>{0, 0, 0, 0});
  for (int j = 0; j < g.dims.y; ++j)
    for (int i = 0; i < g.dims.x; ++i) CHECK(fields.labels[size_t(fields.material_at(glm::dvec3(i, j, 10)))] == 2);
  CHECK(fields.labels[size_t(fields.material_at(glm::dvec3(5, 5, 4)))] == 3);
  CHECK(fields.voxel_counts[3] == 1);
  // The layer's interfaces sit between the voxel centres, near the voxel faces (z = 9.5 and 10.5).
  auto crossing = [&](size_t a, size_t b, double z0, double z1) {
    return bisect([&](double z) { return fields.fields[a].sample_cubic({12.3, 7.6, z}) - fields.fields[b].sample_cubic({12.3, 7.6, z}); }, z0, z1);
  };
  CHECK(crossing(2, 0, 9.0, 10.0) == doctest::Approx(9.5).epsilon(0.03));
  CHECK(crossing(2, 1, 10.0, 11.0) == doctest::Approx(10.5).epsilon(0.03));
}

TEST_CASE("tightening rounds a cube's corners to radius r and leaves its faces") {
  Grid g{{32, 32, 32}, {1, 1, 1}, {0, 0, 0}};
  std::vector<uint16_t> labels(g.voxel_count());
  for (int k = 0; k < 32; ++k)
    for (int j = 0; j < 32; ++j)
      for (int i = 0; i < 32; ++i) labels[g.index(i, j, k)] = i >= 8 && i < 24 && j >= 8 && j < 24 && k >= 8 && k < 24;
  const glm::dvec3 c(15.5);  // the cube spans 7.5 .. 23.5, half side 8
  auto zero_along = [&](const IndicatorFields& f, const glm::dvec3& dir, double t1) {
    return bisect([&](double t) { return f.fields[1].sample_cubic(c + t * dir) - f.fields[0].sample_cubic(c + t * dir); }, 0.0, t1);
  };
  const glm::dvec3 diagonal = glm::normalize(glm::dvec3(1, 1, 1)), face(1, 0, 0), edge = glm::normalize(glm::dvec3(1, 1, 0));
  IndicatorOptions plain;
  plain.tighten_radius = 0;
  IndicatorOptions tight;
  tight.tighten_radius = 3.0;
  const auto f0 = build_indicator_fields(g, labels.data(), plain);
  const auto f3 = build_indicator_fields(g, labels.data(), tight);
  const double corner0 = zero_along(f0, diagonal, 15.0), corner3 = zero_along(f3, diagonal, 15.0);
  const double edge0 = zero_along(f0, edge, 13.0), edge3 = zero_along(f3, edge, 13.0);
  const double face0 = zero_along(f0, face, 11.0), face3 = zero_along(f3, face, 11.0);
  MESSAGE("corner " << corner0 << " -> " << corner3 << ", edge " << edge0 << " -> " << edge3 << ", face " << face0
                    << " -> " << face3 << "; voxels moved " << f3.tightened_voxels[1]);
  // A corner rounded to radius 3 reaches (8 - 3) * sqrt(3) + 3 = 11.66 along the diagonal, an edge 5 sqrt(2) + 3 =
  // 10.07 along its bisector; the sharp cube reaches 13.86 and 11.31. The flow may stop short of the limit radius.
  CHECK(corner3 < corner0 - 1.0);
  CHECK(corner3 > 11.66 - 0.5);
  CHECK(edge3 < edge0 - 0.4);
  CHECK(edge3 > 10.07 - 0.5);
  CHECK(face3 == doctest::Approx(face0).epsilon(0.01));
  CHECK(f3.tightened_voxels[1] > 0);
  CHECK(f3.protected_voxels == 0);
}

TEST_CASE("cubic samples anywhere, NaN and far outside included, are the clamped grid's: finite, no wild reads") {
  // A Newton projection whose tangent vanished once passed NaN here (head phantom at 100^3): the int conversion of
  // floor(NaN) read outside the bricks and crashed `cpmesh fields`.
  const auto vol = cpmesh::test::make_volume(cpmesh::io::SynthShape::sphere, 24, 8.0);
  const auto fields = cpmesh::fields::build_indicator_fields(vol.grid, vol.labels.data(), {});
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const auto& f = fields.fields[1];
  for (const glm::dvec3 p : {glm::dvec3(nan, 3, 4), glm::dvec3(1e300, -1e300, 5), glm::dvec3(inf, -inf, nan),
                             glm::dvec3(-3e9, 2e9, 12)}) {
    glm::dvec3 g;
    const double v = f.sample_cubic(p, &g);
    CHECK(std::isfinite(v));
    CHECK(std::isfinite(g.x + g.y + g.z));
  }
  // Far outside equals just outside: both clamp to the same face samples.
  CHECK(f.sample_cubic({1e12, 12.3, 11.8}) == f.sample_cubic({40, 12.3, 11.8}));
}

TEST_CASE("cubic samples of several fields agree with a plain Catmull-Rom of the voxel values, bricks and faces") {
  // sample_cubic_many gathers by brick, up to 8 per field, resolved once per call (constant bricks have no data):
  // compare with the textbook tricubic on voxel values read one by one with at().
  const Grid grid{{21, 19, 18}, {1.0, 1.0, 1.0}, {0.0, 0.0, 0.0}};
  // c: constant everywhere; d: 0 but in one corner's bricks (a junction offset's shape: a sample whose bricks are all
  // constant 0 skips the gather, and next to the corner it must not)
  BrickField a(grid, -4.0f), b(grid, 2.5f), c(grid, 0.0f), d(grid, 0.0f);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> value(-4.0f, 4.0f);
  // a: allocated bricks with varied values except the brick at the origin and the last along x (constant); b: a
  // smooth field in some bricks only.
  for (int k = 0; k < grid.dims.z; ++k)
    for (int j = 0; j < grid.dims.y; ++j)
      for (int i = 0; i < grid.dims.x; ++i) {
        const bool constant_brick = (i < 8 && j < 8 && k < 8) || i >= 16;
        if (!constant_brick) a.set(i, j, k, value(rng));
        if (j >= 8) b.set(i, j, k, float(0.3 * i - 0.2 * j + 0.1 * k * k / 10.0));
        if (i >= 16 && j >= 8 && k >= 8) d.set(i, j, k, value(rng));
      }
  auto catmull_rom = [](double t, int s) {  // weight of sample s (0..3 at -1, 0, 1, 2) at t
    const double t2 = t * t, t3 = t2 * t;
    const double w[4] = {0.5 * (-t3 + 2 * t2 - t), 0.5 * (3 * t3 - 5 * t2 + 2), 0.5 * (-3 * t3 + 4 * t2 + t),
                         0.5 * (t3 - t2)};
    return w[s];
  };
  auto reference = [&](const BrickField& f, const glm::dvec3& p) {
    const glm::ivec3 base(glm::floor(p));
    const glm::dvec3 t = p - glm::floor(p);
    double v = 0;
    for (int z = 0; z < 4; ++z)
      for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x)
          v += catmull_rom(t.x, x) * catmull_rom(t.y, y) * catmull_rom(t.z, z) *
               double(f.at(base.x + x - 1, base.y + y - 1, base.z + z - 1));
    return v;
  };
  const BrickField* all[4] = {&a, &b, &c, &d};
  std::uniform_real_distribution<double> u(-1.5, 1.0);
  double worst = 0, worst_gradient = 0;
  for (int n = 0; n < 4000; ++n) {
    // Anywhere in the grid and up to 1.5 voxels beyond its faces (clamped samples).
    const glm::dvec3 p((grid.dims.x + 1.5) * (u(rng) + 1.5) / 2.5 - 1.5, (grid.dims.y + 1.5) * (u(rng) + 1.5) / 2.5 - 1.5,
                       (grid.dims.z + 1.5) * (u(rng) + 1.5) / 2.5 - 1.5);
    double values[4];
    glm::dvec3 gradients[4];
    BrickField::sample_cubic_many(all, 4, p, values, gradients);
    for (int m = 0; m < 4; ++m) {
      worst = std::max(worst, std::fabs(values[m] - reference(*all[m], p)));
      // The gradient against central differences of the reference (Catmull-Rom is C1).
      for (int axis = 0; axis < 3; ++axis) {
        glm::dvec3 e(0.0);
        e[axis] = 1e-4;
        // Skip points within 1e-4 of a sample plane, where the one-sided pieces differ in their second derivative.
        if (std::fabs(p[axis] - std::round(p[axis])) < 2e-4) continue;
        const double fd = (reference(*all[m], p + e) - reference(*all[m], p - e)) / 2e-4;
        worst_gradient = std::max(worst_gradient, std::fabs(gradients[m][axis] - fd));
      }
    }
  }
  // sample_linear_many gives each field's sample_linear bit for bit (material_at's argmax compares them).
  size_t linear_mismatches = 0;
  for (int n = 0; n < 2000; ++n) {
    const glm::dvec3 p((grid.dims.x + 1.5) * (u(rng) + 1.5) / 2.5 - 1.5, (grid.dims.y + 1.5) * (u(rng) + 1.5) / 2.5 - 1.5,
                       (grid.dims.z + 1.5) * (u(rng) + 1.5) / 2.5 - 1.5);
    double values[4];
    BrickField::sample_linear_many(all, 4, p, values);
    for (int m = 0; m < 4; ++m) linear_mismatches += values[m] != all[m]->sample_linear(p);
  }
  CHECK(linear_mismatches == 0);
  MESSAGE("sample_cubic_many vs reference: value " << worst << ", gradient " << worst_gradient);
  CHECK(worst < 1e-9);             // measured 7e-15
  CHECK(worst_gradient < 1e-5);    // central differences: measured 1.4e-7

  // Brick by brick (the embedding's whole-volume passes read them so): the storage or the constant of each brick
  // gives every voxel's at().
  size_t mismatches = 0, from_data = 0;
  for (const BrickField* f : all)
    for (int k = 0; k < grid.dims.z; ++k)
      for (int j = 0; j < grid.dims.y; ++j)
        for (int i = 0; i < grid.dims.x; ++i) {
          const glm::ivec3 brick = glm::ivec3(i, j, k) / BrickField::kBrick, o = glm::ivec3(i, j, k) - brick * BrickField::kBrick;
          const float* data = f->brick_values(brick);
          from_data += data != nullptr;
          const float v = data ? data[(o.z * BrickField::kBrick + o.y) * BrickField::kBrick + o.x] : f->brick_constant(brick);
          mismatches += v != f->at(i, j, k);
        }
  CHECK(mismatches == 0);
  CHECK(from_data > 0);
  CHECK(c.brick_values(glm::ivec3(0)) == nullptr);
  CHECK(c.brick_constant(glm::ivec3(0)) == 0.0f);
}

TEST_CASE("a small island's fields keep island_margin from 0 at its voxel centres; a layer's are left alone") {
  // A 2 x 2 x 1 island of label 3 inside label 1. The first Gaussian pass takes its fields near 0 at its voxel
  // centres; held at the margin there, the island comes out of the smoothing rounder, and its mesh in the islands
  // corpus volume is no flat double layer of slivers (docs/corpus.md).
  Grid g{{16, 16, 16}, {1, 1, 1}, {0, 0, 0}};
  std::vector<uint16_t> labels(g.voxel_count(), 1);
  for (int j = 7; j < 9; ++j)
    for (int i = 7; i < 9; ++i) labels[g.index(i, j, 8)] = 3;
  struct Island {
    double centre, below, above;  // the island's field at a voxel centre; its faces on the line through its middle
  };
  auto island = [&](const IndicatorOptions& options) {
    const auto fields = build_indicator_fields(g, labels.data(), options);
    REQUIRE(fields.labels == std::vector<uint16_t>{1, 3});
    auto d = [&](double z) { return fields.fields[1].sample_cubic({7.5, 7.5, z}) - fields.fields[0].sample_cubic({7.5, 7.5, z}); };
    REQUIRE(d(8.0) > 0);
    return Island{fields.fields[1].at(7, 7, 8), bisect(d, 6.5, 8.0), bisect(d, 8.0, 9.5)};
  };
  IndicatorOptions plain, margin;
  plain.island_margin = 0;
  margin.island_margin = 0.4;
  const Island without = island(plain), with = island(margin);
  MESSAGE("island field at a centre " << without.centre << " -> " << with.centre << ", faces at z = " << without.below
                                      << ", " << without.above << " -> " << with.below << ", " << with.above);
  CHECK(with.centre > without.centre + 0.2);
  CHECK(with.above - with.below > without.above - without.below);
  CHECK(with.above - with.below < 1.6);  // the voxel is 1 thick: rounder, not much larger
  CHECK(with.below + with.above == doctest::Approx(16.0).epsilon(0.01));
  // A one-voxel layer across the volume is no island: the margin leaves its fields as they are.
  std::vector<uint16_t> layer(g.voxel_count(), 1);
  for (int j = 0; j < 16; ++j)
    for (int i = 0; i < 16; ++i) layer[g.index(i, j, 8)] = 3;
  const auto layer_with = build_indicator_fields(g, layer.data(), margin);
  const auto layer_without = build_indicator_fields(g, layer.data(), plain);
  for (double z = 6; z <= 10; z += 0.25)
    CHECK(layer_with.fields[1].sample_cubic({7.3, 6.6, z}) == layer_without.fields[1].sample_cubic({7.3, 6.6, z}));
}
