// The exact tree walk against the brute-force reference: energies, gradients, the interaction rule between
// features, and the work budget that keeps every invocation far below lavapipe's loop limit.
#include <doctest/doctest.h>

#include <random>

#include "gpu_fixture.h"
#include "octree/morton.h"
#include "octree/octree_build.h"
#include "octree/tree_walk.h"
#include "ref/particle_energy.h"

using namespace cpmesh;
using cpmesh::test::GpuFixture;

namespace {

struct WalkResult {
  std::vector<glm::vec4> result;
  std::vector<uint32_t> counts;
};

WalkResult walk(gpu::Context& ctx, const std::vector<glm::vec4>& particles, const std::vector<uint32_t>& features,
                const std::vector<uint64_t>& masks, float extent, uint32_t walkers = ~0u) {
  const uint32_t n = uint32_t(particles.size()), leaf = 16;
  octree::MortonSort sorter(ctx);
  octree::OctreeBuild build(ctx);
  octree::OctreeMoments moments(ctx);
  octree::TreeWalk tree_walk(ctx);
  const size_t capacity = octree::OctreeBuild::node_capacity(n, leaf);
  gpu::Buffer<glm::vec4> pb(ctx, particles, "particles"), result(ctx, n, "result");
  octree::NodeMoments m(ctx, capacity);
  gpu::Buffer<uint32_t> fb(ctx, features, "features"), order(ctx, n, "order"), counts(ctx, n, "counts"),
      visits(ctx, n, "visits");
  gpu::Buffer<uint64_t> mb(ctx, masks, "feature masks"), keys(ctx, n, "keys");
  gpu::Buffer<glm::uvec4> nodes(ctx, capacity, "nodes");
  gpu::Buffer<glm::uvec2> info(ctx, 22, "level info");
  gpu::Sequence seq(ctx);
  sorter.record(seq, pb, octree::MortonBox::around(glm::vec3(0.0f), glm::vec3(extent)), keys, order, n);
  build.record(seq, keys, n, leaf, nodes, info);
  moments.record(seq, nodes, info, order, pb, fb, mb, m, n);
  seq.fill(counts, 0);
  seq.barrier();
  tree_walk.record(seq, nodes, m, order, pb, fb, mb, result, counts, visits, n, walkers);
  seq.submit_and_wait();
  return {result.download(), counts.download()};
}

}  // namespace

TEST_CASE_FIXTURE(GpuFixture, "tree walk energies and gradients match brute force, with the feature hierarchy") {
  // Feature 0: interface {0,1}; 1: triple curve {0,1,2} (bounds 0 and 2); 2: interface {1,2}; 3: interface {3,4}.
  const std::vector<uint64_t> masks = {0b11, 0b111, 0b110, 0b11000};
  for (uint32_t n : {1u, 64u, 3000u}) {
    CAPTURE(n);
    std::mt19937 rng(n);
    std::uniform_real_distribution<float> u(0.0f, 20.0f), h(0.8f, 2.5f);
    std::vector<glm::vec4> particles(n);
    std::vector<uint32_t> features(n);
    for (uint32_t i = 0; i < n; ++i) {
      particles[i] = glm::vec4(u(rng), u(rng), u(rng), h(rng));
      features[i] = uint32_t(rng() % masks.size());
    }
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

TEST_CASE_FIXTURE(GpuFixture, "a walk that would pass lavapipe's loop limit is cut by the budget and reported") {
  const uint32_t n = 70000, walkers = 64;  // all within each other's support: 70k pairs each without the budget
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<glm::vec4> particles(n);
  for (auto& p : particles) p = glm::vec4(u(rng), u(rng), u(rng), 10.0f);
  const auto got = walk(ctx, particles, std::vector<uint32_t>(n, 0), {0b11}, 1.0f, walkers);
  size_t flagged = 0, walked = 0;
  for (uint32_t c : got.counts) {
    flagged += (c & octree::TreeWalk::kBudgetExceeded) != 0;
    walked += c != 0;
  }
  CHECK(walked == walkers);
  CHECK(flagged == walkers);
}
