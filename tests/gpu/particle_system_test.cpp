// The GPU particle iteration against its C++ reference, and convergence on the sphere.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "fields/fields_stage.h"
#include "fields_volumes.h"
#include "gpu_fixture.h"
#include "particles/particle_system.h"
#include "ref/advect.h"
#include "ref/particle_energy.h"

using namespace cpmesh;
using cpmesh::test::GpuFixture;

namespace {

struct SphereSetup {
  test::FieldsVolume vol;
  fields::FieldsResult fields;
};

const SphereSetup& sphere() {
  static const SphereSetup s = [] {
    SphereSetup r{test::make_volume(io::SynthShape::sphere, 48, 16.0), {}};
    fields::FieldsOptions o;
    o.sizing.h_max = 3.0;  // about 450 particles at hexagonal spacing on this sphere
    r.fields = fields::build_fields(r.vol.grid, r.vol.labels.data(), o);
    return r;
  }();
  return s;
}

// n particles on the sphere's interface: random directions projected with the embedding (h from its sizing).
std::vector<glm::vec4> seed(const SphereSetup& s, uint32_t n, uint32_t rng_seed) {
  std::mt19937 rng(rng_seed);
  std::normal_distribution<double> n01;
  std::vector<glm::vec4> out;
  while (out.size() < n) {
    const glm::dvec3 dir = glm::normalize(glm::dvec3(n01(rng), n01(rng), n01(rng)));
    const auto cp = ref::cp_lookup(s.fields.embedding, glm::vec3(s.vol.centre + 16.0 * dir), 0);
    if (cp.valid) out.push_back(cp.value);
  }
  return out;
}

}  // namespace

TEST_CASE_FIXTURE(GpuFixture, "one GPU iteration matches the reference iteration") {
  const auto& s = sphere();
  const auto start = seed(s, 2000, 1);
  const std::vector<uint32_t> features(start.size(), 0);
  particles::AdvectionOptions opt;
  particles::ParticleSystem system(ctx, s.fields.embedding, start, features, opt);
  const auto stats = system.step();
  const auto got = system.particles();

  auto want = start;
  const std::vector<uint64_t> masks = {0b11};
  const auto walk = ref::particle_energy(start, features, masks);
  const uint32_t lost = ref::advect(s.fields.embedding, want, features, walk, opt.alpha, opt.max_move);
  CHECK(stats.lost == lost);
  double total = 0;
  for (const auto& w : walk) total += w.w;
  CHECK(stats.energy == doctest::Approx(total).epsilon(1e-4));
  float worst = 0, moved = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    worst = std::max(worst, glm::length(glm::vec3(got[i]) - glm::vec3(want[i])));
    moved = std::max(moved, glm::length(glm::vec3(want[i]) - glm::vec3(start[i])));
  }
  MESSAGE("positions after one step: max GPU - reference " << worst << " voxel (largest move " << moved << ")");
  CHECK(moved > 0.1f);
  CHECK(worst < 1e-4f);
}

TEST_CASE_FIXTURE(GpuFixture, "sphere with a fixed particle count converges to an even sampling on the surface") {
  const auto& s = sphere();
  const auto start = seed(s, 450, 2);
  particles::ParticleSystem system(ctx, s.fields.embedding, start, std::vector<uint32_t>(start.size(), 0));
  const auto run = system.run();
  const auto end = system.particles();
  MESSAGE("iterations " << run.iterations << ", energy " << run.energies.front() << " -> " << run.energies.back());
  CHECK(run.converged);
  // On the surface: the embedding maps every particle to itself.
  float off = 0;
  for (const auto& p : end) {
    const auto cp = ref::cp_lookup(s.fields.embedding, glm::vec3(p), 0);
    REQUIRE(cp.valid);
    off = std::max(off, glm::length(glm::vec3(cp.value) - glm::vec3(p)));
  }
  // Even: nearest-neighbour distances vary little.
  std::vector<double> nn(end.size(), 1e30);
  for (size_t i = 0; i < end.size(); ++i)
    for (size_t j = 0; j < end.size(); ++j)
      if (i != j) nn[i] = std::min(nn[i], double(glm::length(glm::vec3(end[i]) - glm::vec3(end[j]))));
  const double mean = std::accumulate(nn.begin(), nn.end(), 0.0) / double(nn.size());
  double var = 0;
  for (double d : nn) var += (d - mean) * (d - mean);
  const double spread = std::sqrt(var / double(nn.size())) / mean;
  MESSAGE("distance to the surface max " << off << " voxel; nearest-neighbour spread " << spread << " (mean " << mean << ")");
  CHECK(off < 0.01f);
  CHECK(spread < 0.1);
}
