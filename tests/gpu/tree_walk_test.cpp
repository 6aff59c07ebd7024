// The exact tree walk against the brute-force reference: energies, gradients, the interaction rule between
// features, and the work budget that keeps every invocation far below lavapipe's loop limit.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstring>
#include <random>
#include <stdexcept>

#include "cpmesh/shaders.h"
#include "gpu_fixture.h"
#include "octree/morton.h"
#include "octree/octree_build.h"
#include "octree/tree_walk.h"
#include "ref/particle_energy.h"

using namespace cpmesh;
using cpmesh::test::GpuFixture;

namespace {

// n particles in a 20^3 box, h in [0.8, 2.5], each on one of `feature_count` features at random.
void random_particles(uint32_t n, uint32_t seed, size_t feature_count, std::vector<glm::vec4>& particles,
                      std::vector<uint32_t>& features) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 20.0f), h(0.8f, 2.5f);
  particles.resize(n);
  features.resize(n);
  for (uint32_t i = 0; i < n; ++i) {
    particles[i] = glm::vec4(u(rng), u(rng), u(rng), h(rng));
    features[i] = uint32_t(rng() % feature_count);
  }
}

// Particles on the device, Morton-sorted into an octree with its moments (the walks' input).
struct Tree {
  Tree(gpu::Context& ctx, const std::vector<glm::vec4>& particles, const std::vector<uint32_t>& features,
       const std::vector<fields::MaterialSet>& masks, float extent)
      : n(uint32_t(particles.size())),
        pb(ctx, particles, "particles"),
        m(ctx, octree::OctreeBuild::node_capacity(n, kLeaf)),
        order(ctx, n, "order"),
        visits(ctx, n, "visits"),
        pm(ctx, octree::particle_masks(features, masks), "particle masks"),
        nodes(ctx, octree::OctreeBuild::node_capacity(n, kLeaf), "nodes") {
    octree::MortonSort sorter(ctx);
    octree::OctreeBuild build(ctx);
    octree::OctreeMoments moments(ctx, fields::needs_exact_sets(masks));
    gpu::Buffer<uint64_t> keys(ctx, n, "keys");
    gpu::Buffer<glm::uvec2> info(ctx, 22, "level info");
    gpu::Sequence seq(ctx);
    sorter.record(seq, pb, octree::MortonBox::around(glm::vec3(0.0f), glm::vec3(extent)), keys, order, n);
    build.record(seq, keys, n, kLeaf, nodes, info);
    moments.record(seq, nodes, info, order, pb, pm, m, n);
    seq.submit_and_wait();
  }
  static constexpr uint32_t kLeaf = 16;
  uint32_t n;
  gpu::Buffer<glm::vec4> pb;
  octree::NodeMoments m;
  gpu::Buffer<uint32_t> order, visits;
  gpu::Buffer<glm::uvec4> pm, nodes;  // per-particle masks (the moments' and the walks'); the octree
};

struct WalkResult {
  std::vector<glm::vec4> result;
  std::vector<uint32_t> counts;
};

WalkResult walk(gpu::Context& ctx, const std::vector<glm::vec4>& particles, const std::vector<uint32_t>& features,
                const std::vector<fields::MaterialSet>& masks, float extent, uint32_t walkers = ~0u) {
  const Tree t(ctx, particles, features, masks, extent);
  octree::TreeWalk tree_walk(ctx, fields::needs_exact_sets(masks));
  gpu::Buffer<glm::vec4> result(ctx, t.n, "result");
  gpu::Buffer<uint32_t> counts(ctx, t.n, "counts");
  gpu::Sequence seq(ctx);
  seq.fill(counts, 0).barrier();
  tree_walk.record(seq, t.nodes, t.m, t.order, t.pb, t.pm, result, counts, t.visits, t.n, walkers);
  seq.submit_and_wait();
  return {result.download(), counts.download()};
}

}  // namespace

TEST_CASE_FIXTURE(GpuFixture, "tree walk energies and gradients match brute force, with the feature hierarchy") {
  // Feature 0: interface {7,300}; 1: triple curve {7,300,1001} (bounds 0 and 2); 2: interface {300,1001}; 3:
  // interface {2,65534}: material indices far beyond 64, the slots compared ({2,62,300} passes the mask test of
  // {2,65534}, as 65534 % 64 = 62, but does not include it). Or the same hierarchy below 64 (the masks alone).
  std::vector<fields::MaterialSet> masks = {{7, 300}, {7, 300, 1001}, {300, 1001}, {2, 65534}};
  SUBCASE("indices beyond 64") { masks.push_back({2, 62, 300}); }
  SUBCASE("indices below 64") { masks = {{0, 1}, {0, 1, 2}, {1, 2}, {3, 4}, {6, 7}}; }
  CAPTURE(fields::needs_exact_sets(masks));
  for (uint32_t n : {1u, 64u, 3000u}) {
    CAPTURE(n);
    std::vector<glm::vec4> particles;
    std::vector<uint32_t> features;
    random_particles(n, n, masks.size(), particles, features);
    const auto got = walk(ctx, particles, features, masks, 20.0f);
    const auto want = ref::particle_energy(particles, features, masks);
    uint64_t pairs = 0;
    for (uint32_t i = 0; i < n; ++i) {
      CHECK((got.counts[i] & octree::TreeWalk::kBudgetExceeded) == 0);
      pairs += got.counts[i];
      CHECK(got.result[i].w == doctest::Approx(want[i].w).epsilon(1e-4).scale(1.0));
      CHECK(glm::length(glm::vec3(got.result[i]) - glm::vec3(want[i])) <= 1e-4f * (1.0f + glm::length(glm::vec3(want[i]))));
    }
    if (n == 3000) CHECK(pairs > 1000);  // the case exercises real interactions
  }
  // The rule itself: a curve particle is not pushed by an interface particle, the interface particle is.
  const std::vector<glm::vec4> two = {glm::vec4(5, 5, 5, 1), glm::vec4(5.5f, 5, 5, 1)};
  const auto r = walk(ctx, two, {1, 0}, masks, 20.0f);
  CHECK(r.result[0].w == 0.0f);
  CHECK(r.result[1].w > 0.0f);
  CHECK(r.result[1].x < 0.0f);  // energy grows towards the curve particle: -gradient pushes the interface one away
}

TEST_CASE("the walks' per-particle masks are their features' material sets in two words") {
  const std::vector<fields::MaterialSet> masks = {{0, 1}, {5, 300, 4000}};
  const auto got = octree::particle_masks({1, 0, 1}, masks);
  REQUIRE(got.size() == 3);
  // mask64 (bits 5, 300 % 64 = 44, 4000 % 64 = 32) in x, y; the slots in z, w.
  CHECK(got[0] == glm::uvec4(1u << 5, 1u << 12 | 1u, 5u | 300u << 16, 4000u | 4000u << 16));
  CHECK(got[1] == glm::uvec4(0b11u, 0u, 0u | 1u << 16, 1u | 1u << 16));
  CHECK(got[2] == got[0]);
  CHECK(octree::particle_masks({}, masks).empty());
  CHECK_THROWS_AS(octree::particle_masks({2}, masks), std::invalid_argument);
}

TEST_CASE_FIXTURE(GpuFixture, "a walk that would pass lavapipe's loop limit is cut by the budget and reported") {
  const uint32_t n = 70000, walkers = 64;  // all within each other's support: 70k pairs each without the budget
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<glm::vec4> particles(n);
  for (auto& p : particles) p = glm::vec4(u(rng), u(rng), u(rng), 10.0f);
  const auto got = walk(ctx, particles, std::vector<uint32_t>(n, 0), {fields::MaterialSet{0, 1}}, 1.0f, walkers);
  size_t flagged = 0, walked = 0;
  for (uint32_t c : got.counts) {
    flagged += (c & octree::TreeWalk::kBudgetExceeded) != 0;
    walked += c != 0;
  }
  CHECK(walked == walkers);
  CHECK(flagged == walkers);
}

TEST_CASE_FIXTURE(GpuFixture, "neighbour lists match brute force, grow past their capacity, and give the walk's energies") {
  const std::vector<fields::MaterialSet> masks = {{7, 300}, {7, 300, 1001}, {300, 1001}, {2, 65534}};
  const uint32_t n = 3000;
  const float skin = 0.5f;
  std::vector<glm::vec4> particles;
  std::vector<uint32_t> features;
  random_particles(n, 7, masks.size(), particles, features);
  const Tree t(ctx, particles, features, masks, 20.0f);
  octree::TreeWalk tree_walk(ctx, fields::needs_exact_sets(masks));
  gpu::Buffer<glm::vec4> result(ctx, n, "result");
  gpu::Buffer<uint32_t> lengths(ctx, n, "lengths"), counts(ctx, n, "counts"), longest(ctx, 1, "longest");
  auto list_walk = [&](uint32_t per_particle, gpu::Buffer<uint32_t>& lists) {
    gpu::Sequence seq(ctx);
    seq.fill(longest, 0).barrier();
    tree_walk.record_lists(seq, t.nodes, t.m, t.order, t.pb, t.pm, lists, lengths, t.visits, longest, n, skin,
                           per_particle);
    seq.submit_and_wait();
    return longest.read(0);
  };
  const auto want = ref::neighbour_lists(particles, features, masks, skin);
  size_t want_longest = 0;
  for (const auto& l : want) want_longest = std::max(want_longest, l.size());
  REQUIRE(want_longest > 4);
  // Too small a capacity: the longest list is still counted in full, and the lengths say which lists overflowed.
  gpu::Buffer<uint32_t> small(ctx, size_t(n) * 4, "lists (4 each)");
  CHECK(list_walk(4, small) == want_longest);
  const uint32_t cap = uint32_t(want_longest);
  gpu::Buffer<uint32_t> lists(ctx, size_t(n) * cap, "lists");
  CHECK(list_walk(cap, lists) == want_longest);
  const auto got = lists.download();
  const auto got_lengths = lengths.download();
  size_t listed = 0;
  for (uint32_t i = 0; i < n; ++i) {
    CAPTURE(i);
    REQUIRE((got_lengths[i] & octree::TreeWalk::kBudgetExceeded) == 0);
    const auto first = got.begin() + ptrdiff_t(size_t(i) * cap);
    std::vector<uint32_t> l(first, first + ptrdiff_t(got_lengths[i]));
    std::sort(l.begin(), l.end());
    CHECK(l == want[i]);
    listed += l.size();
  }
  CHECK(listed > 5000);  // real lists
  // The energy over the lists is the brute-force energy (the lists hold every pair within the support and more).
  gpu::Kernel energy(ctx, shaders::neighbour_energy);
  {
    gpu::Sequence seq(ctx);
    const struct {
      uint32_t n, capacity;
    } push{n, cap};
    seq.dispatch(energy, {t.pb, lists, lengths, result, counts}, push, n);
    seq.submit_and_wait();
  }
  const auto e = result.download();
  const auto e_counts = counts.download();
  const auto e_want = ref::particle_energy(particles, features, masks);
  uint64_t pairs = 0;
  for (uint32_t i = 0; i < n; ++i) {
    CHECK((e_counts[i] & octree::TreeWalk::kBudgetExceeded) == 0);
    pairs += e_counts[i];
    CHECK(e[i].w == doctest::Approx(e_want[i].w).epsilon(1e-4).scale(1.0));
    CHECK(glm::length(glm::vec3(e[i]) - glm::vec3(e_want[i])) <= 1e-4f * (1.0f + glm::length(glm::vec3(e_want[i]))));
  }
  CHECK(pairs > 1000);
  CHECK(pairs < listed);  // the skin's pairs are listed but do not interact
}

TEST_CASE_FIXTURE(GpuFixture, "neighbour drift is the largest move relative to h, as in the reference") {
  const uint32_t n = 5000;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 20.0f), h(0.5f, 2.0f), step(-0.1f, 0.1f);
  std::vector<glm::vec4> anchors(n), particles(n);
  for (uint32_t i = 0; i < n; ++i) {
    anchors[i] = glm::vec4(u(rng), u(rng), u(rng), h(rng));
    particles[i] = anchors[i] + glm::vec4(step(rng), step(rng), step(rng), 0.0f);
  }
  particles[1234] += glm::vec4(0.3f, 0.0f, 0.0f, 0.0f);  // one particle well ahead of the rest
  gpu::Buffer<glm::vec4> pb(ctx, particles, "particles"), ab(ctx, anchors, "anchors");
  gpu::Buffer<uint32_t> drift(ctx, 1, "drift");
  gpu::Kernel kernel(ctx, shaders::neighbour_drift);
  gpu::Sequence seq(ctx);
  seq.fill(drift, 0).barrier().dispatch(kernel, {pb, ab, drift}, n, n);
  seq.submit_and_wait();
  const uint32_t bits = drift.read(0);
  float got;
  std::memcpy(&got, &bits, sizeof got);
  const float want = ref::neighbour_drift(particles, anchors);
  CHECK(want >= 0.3f / 2.0f);
  CHECK(got == doctest::Approx(want).epsilon(1e-6));
}
