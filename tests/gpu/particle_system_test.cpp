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
#include "spacing.h"

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
  const std::vector<fields::MaterialSet> masks = {{0, 1}};
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
  particles::AdvectionOptions opt;
  SUBCASE("exact walk") { opt.theta = 0.0f; }
  SUBCASE("Barnes-Hut walk, theta = 0.75") { opt.theta = 0.75f; }
  CAPTURE(opt.theta);
  particles::ParticleSystem system(ctx, s.fields.embedding, start, std::vector<uint32_t>(start.size(), 0), opt);
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
  const auto [mean, spread] = test::nearest_neighbour_spacing(end);
  MESSAGE("distance to the surface max " << off << " voxel; nearest-neighbour spread " << spread << " (mean " << mean << ")");
  CHECK(off < 0.01f);
  CHECK(spread < 0.1);
}

namespace {

// A simple seeding of every feature (issue 7 brings the real one): quadruple points exactly, then closest points of
// the embedding's blocks that touch their feature, taken greedily when no earlier seed of this or a bounding
// feature is closer than the local h.
void seed_all_features(const fields::ClosestPointEmbedding& E, std::vector<glm::vec4>& particles,
                       std::vector<uint32_t>& features) {
  for (const auto& q : E.quadruple_points) {
    particles.push_back(glm::vec4(glm::vec3(q.position), 1.0f));
    features.push_back(q.feature);
  }
  for (fields::FeatureKind kind : {fields::FeatureKind::triple_curve, fields::FeatureKind::interface}) {
    for (size_t slot = 0; slot < E.keys.size(); ++slot) {
      if (E.keys[slot] == fields::ClosestPointEmbedding::kEmpty) continue;
      const uint32_t f = uint32_t(E.keys[slot] & 0xffff);
      if (E.features[f].kind != kind) continue;
      const uint64_t cell = E.keys[slot] >> 16;
      const glm::vec3 centre(E.grid.voxel(cell));
      const glm::vec4 cp = E.fine[size_t(E.blocks[slot]) * 8];
      if (glm::length(glm::vec3(cp) - centre) > 0.5f) continue;
      bool near = false;
      for (const auto& p : particles)
        if (glm::length(glm::vec3(p) - glm::vec3(cp)) < 0.9f * cp.w) {
          near = true;
          break;
        }
      if (near) continue;
      particles.push_back(cp);
      features.push_back(f);
    }
  }
  for (size_t i = 0; i < E.quadruple_points.size(); ++i) particles[i].w = particles.back().w;  // h near the points
}

}  // namespace

TEST_CASE_FIXTURE(GpuFixture, "wedge ball: curve particles stay on their curves, quadruple points stay, patches hold") {
  const auto vol = test::make_volume(io::SynthShape::wedge_ball, 40);
  fields::FieldsOptions o;
  o.sizing.h_max = 3.0;
  const auto F = fields::build_fields(vol.grid, vol.labels.data(), o);
  const auto& E = F.embedding;
  std::vector<glm::vec4> start;
  std::vector<uint32_t> features;
  seed_all_features(E, start, features);
  REQUIRE(start.size() > 200);
  particles::AdvectionOptions opt;
  opt.max_iterations = 60;
  particles::ParticleSystem system(ctx, E, start, features, opt);
  const auto run = system.run();
  const auto end = system.particles();
  MESSAGE(start.size() << " particles, " << run.iterations << " iterations, energy " << run.energies.front() << " -> "
                       << run.energies.back());
  float curve_off = 0;
  size_t crossed = 0, interface_particles = 0;
  for (size_t i = 0; i < end.size(); ++i) {
    const auto& feat = E.features[features[i]];
    if (feat.kind == fields::FeatureKind::quadruple_point) {
      CHECK(end[i] == start[i]);
      continue;
    }
    const auto cp = ref::cp_lookup(E, glm::vec3(end[i]), features[i]);
    REQUIRE(cp.valid);
    if (feat.kind == fields::FeatureKind::triple_curve) {
      curve_off = std::max(curve_off, glm::length(glm::vec3(cp.value) - glm::vec3(end[i])));
      continue;
    }
    // An interface particle stays on its own patch: no third material wins where it is.
    ++interface_particles;
    const glm::dvec3 at = glm::dvec3(glm::vec3(end[i])) / vol.grid.spacing;
    const double own = F.fields.fields[feat.materials[0]].sample_cubic(at);
    for (size_t m = 0; m < F.fields.material_count(); ++m) {
      if (m == feat.materials[0] || m == feat.materials[1]) continue;
      if (F.fields.fields[m].sample_cubic(at) > own + 0.05) {
        ++crossed;
        break;
      }
    }
  }
  MESSAGE("curve particles: max distance to their curve " << curve_off << " voxel; interface particles beyond their patch: "
                                                          << crossed << " of " << interface_particles);
  CHECK(curve_off < 0.05f);
  CHECK(crossed == 0);
}

TEST_CASE_FIXTURE(GpuFixture, "refitting the octree between rebuilds gives the iterations of a rebuild every step") {
  // The exact walk prunes by the moments' boxes, which the refit recomputes from the current positions: the same
  // pairs interact whatever the tree's topology, so only the summation order differs. From a random start the runs
  // then drift apart by rounding (1e-5 voxel after the first refitted step, measured 0.008 after 12), so positions are
  // compared over the first steps and energies over all.
  const auto& s = sphere();
  const auto start = seed(s, 1500, 5);
  const std::vector<uint32_t> features(start.size(), 0);
  particles::AdvectionOptions every, refit;
  every.rebuild_every = 1;
  refit.rebuild_every = 8;
  every.neighbour_skin = refit.neighbour_skin = 0.0f;  // the walk every step (the lists are tested below)
  particles::ParticleSystem a(ctx, s.fields.embedding, start, features, every);
  particles::ParticleSystem b(ctx, s.fields.embedding, start, features, refit);
  double worst_energy = 0;
  for (int it = 0; it < 12; ++it) {
    const double ea = a.step().energy, eb = b.step().energy;
    worst_energy = std::max(worst_energy, std::fabs(ea - eb) / ea);
    if (it >= 3) continue;
    const auto pa = a.particles(), pb = b.particles();
    double apart = 0, moved = 0;
    for (size_t i = 0; i < pa.size(); ++i) {
      apart = std::max(apart, double(glm::length(glm::vec3(pa[i]) - glm::vec3(pb[i]))));
      moved = std::max(moved, double(glm::length(glm::vec3(pa[i]) - glm::vec3(start[i]))));
    }
    MESSAGE("step " << it + 1 << ": particles moved up to " << moved << ", the runs " << apart << " apart");
    CHECK(moved > 0.05);
    CHECK(apart < 1e-4);
  }
  MESSAGE("energies within " << worst_energy << " (relative) over 12 steps");
  // Measured: mostly under 1e-7 a step, with single-step transients (1.4e-5 at step 7 of 12, 8e-8 again at step 8,
  // on the embedding of 7463e22; 7.5e-7 at most on the one before): rounding, amplified for a step by some pair.
  CHECK(worst_energy < 5e-5);
}

TEST_CASE_FIXTURE(GpuFixture, "neighbour lists give the iterations of a walk every step, rebuilt as the particles drift") {
  // Lists (the default) against walking a freshly built octree every step: the same pairs interact while the drift
  // bound holds, so only the summation order differs (as in the refit test above). From a random start every step
  // moves some particle past the bound; from a partly relaxed one the lists last several steps, and an energy off by
  // a missed pair would show.
  const auto& s = sphere();
  const auto random_start = seed(s, 450, 5);  // the sizing's hexagonal count
  const std::vector<uint32_t> features(random_start.size(), 0);
  particles::AdvectionOptions walk, lists, thin;
  walk.rebuild_every = 1;
  walk.neighbour_skin = 0.0f;
  REQUIRE(lists.neighbour_skin > 0.0f);
  // Lists whose bound is below most steps' moves: built only after a step that moved less. Never rebuilt, they would
  // miss pairs (below).
  thin.neighbour_skin = 0.1f;
  std::vector<glm::vec4> start;
  {
    particles::ParticleSystem relax(ctx, s.fields.embedding, random_start, features, walk);
    for (int it = 0; it < 30; ++it) relax.step();
    start = relax.particles();
  }
  particles::ParticleSystem a(ctx, s.fields.embedding, start, features, walk);
  particles::ParticleSystem b(ctx, s.fields.embedding, start, features, lists);
  particles::ParticleSystem c(ctx, s.fields.embedding, start, features, thin);
  CHECK_FALSE(a.uses_lists());
  CHECK(b.uses_lists());
  double worst_energy = 0;
  int64_t worst_pairs = 0;
  for (int it = 0; it < 16; ++it) {
    // A build only after a step that moved no particle farther than the lists' bound (none before the first step).
    const bool thin_may_build = c.last_move() <= thin.drift_limit();
    const int thin_builds_before = c.list_builds();
    const auto b_before = b.particles();
    const double ea = a.step().energy, eb = b.step().energy, ec = c.step().energy;
    CHECK(c.list_builds() - thin_builds_before <= int(thin_may_build));
    worst_energy = std::max({worst_energy, std::fabs(ea - eb) / ea, std::fabs(ea - ec) / ea});
    // The pairs that interacted (d < 1) in this step's energy: the same pairs in all three.
    const int64_t pairs = int64_t(a.last_pair_count());
    worst_pairs = std::max<int64_t>({worst_pairs, std::llabs(int64_t(b.last_pair_count()) - pairs),
                                     std::llabs(int64_t(c.last_pair_count()) - pairs)});
    if (it == 0) {
      // The first step walked (no move measured yet) and measured the largest move from the start.
      CHECK(b.list_builds() == 0);
      CHECK(c.list_builds() == 0);
      CHECK(b.last_move() == doctest::Approx(ref::neighbour_drift(b.particles(), start)).epsilon(1e-5));
      CHECK(b.last_move() > 0.0f);
      CHECK(b.last_move() <= lists.drift_limit());  // a partly relaxed start: the next step builds lists
    }
    if (it == 1) {
      // Built at the step's start: the drift is every particle's move from there.
      CHECK(b.list_builds() == 1);
      CHECK(b.drift() == doctest::Approx(ref::neighbour_drift(b.particles(), b_before)).epsilon(1e-5));
      CHECK(b.drift() > 0.0f);
    }
    if (it >= 3) continue;
    const auto pa = a.particles(), pb = b.particles();
    double apart = 0;
    for (size_t i = 0; i < pa.size(); ++i)
      apart = std::max(apart, double(glm::length(glm::vec3(pa[i]) - glm::vec3(pb[i]))));
    CHECK(apart < 1e-4);
  }
  MESSAGE("energies within " << worst_energy << " (relative) over 16 steps; " << b.list_builds() << " list builds, "
                             << b.list_capacity() << " entries per particle; skin " << thin.neighbour_skin << ": "
                             << c.list_builds() << " builds");
  CHECK(b.list_builds() >= 2);   // the drift bound made it rebuild
  CHECK(b.list_builds() <= 8);   // and the lists served several steps each
  CHECK(c.list_builds() >= 3);  // some steps were slow enough, and their lists soon expired (measured: 7 builds)
  // From the random start the first steps move particles the full max_move h, beyond the bound: they walk.
  particles::ParticleSystem d(ctx, s.fields.embedding, random_start, features, lists);
  d.step();
  CHECK(d.last_move() > lists.drift_limit());
  d.step();
  CHECK(d.list_builds() == 0);
  // Measured: the same pair counts every step (4,926 -> 4,802); with lists of skin 0.02 never rebuilt, 46 pairs short
  // by step 16. A pair at d = 1 within rounding may still flip between the runs.
  MESSAGE("pair counts differ by at most " << worst_pairs);
  CHECK(worst_pairs <= 2);
  CHECK(worst_energy < 5e-5);
}

TEST_CASE_FIXTURE(GpuFixture, "a system of no particles steps and runs, with lists or without") {
  const auto& s = sphere();
  for (float skin : {0.0f, 0.5f}) {
    CAPTURE(skin);
    particles::AdvectionOptions o;
    o.neighbour_skin = skin;
    particles::ParticleSystem system(ctx, s.fields.embedding, {}, {}, o);
    CHECK_FALSE(system.uses_lists());
    CHECK(system.step().energy == 0.0);
    const auto r = system.run();
    CHECK(r.converged);
    CHECK(r.iterations == 0);
    CHECK(system.particles().empty());
  }
}
