// The GPU octree build against ref::build_octree, and the reference against the octree's definition.
#include <doctest/doctest.h>

#include <algorithm>
#include <random>

#include "gpu_fixture.h"
#include "octree/octree_build.h"
#include "octree/morton.h"
#include "ref/octree_build.h"
#include "ref/octree_moments.h"

using namespace cpmesh;
using cpmesh::test::GpuFixture;

namespace {

std::vector<uint64_t> sorted_keys(uint32_t n, uint64_t seed, bool clustered) {
  std::mt19937_64 rng(seed);
  std::vector<uint64_t> k(n);
  for (auto& x : k) {
    x = rng() >> 1;  // 63 bits
    if (clustered) x &= ~((uint64_t(1) << 40) - 1) & ((uint64_t(1) << 48) - 1);  // few distinct prefixes, duplicates
  }
  std::sort(k.begin(), k.end());
  return k;
}

}  // namespace

TEST_CASE("reference octree: children partition their parent, leaves are small, prefixes agree") {
  const auto keys = sorted_keys(5000, 3, false);
  const auto t = ref::build_octree(keys, 8);
  uint64_t leaf_particles = 0;
  for (const auto& node : t.nodes) {
    const uint32_t level = node.w >> 8, children = node.w & 0xff;
    if (children == 0) {
      CHECK((node.y <= 8 || level == 21));
      leaf_particles += node.y;
      continue;
    }
    CHECK(node.y > 8);
    uint32_t covered = node.x;
    for (uint32_t c = 0; c < children; ++c) {
      const auto& child = t.nodes[node.z + c];
      CHECK(child.x == covered);
      CHECK((child.w >> 8) == level + 1);
      covered += child.y;
      const int shift = 63 - 3 * int(level + 1);
      CHECK((keys[child.x] >> shift) == (keys[child.x + child.y - 1] >> shift));
    }
    CHECK(covered == node.x + node.y);
  }
  CHECK(leaf_particles == keys.size());
}

TEST_CASE_FIXTURE(GpuFixture, "GPU octree with a depth cap matches the reference; nodes at the cap are leaves") {
  octree::OctreeBuild build(ctx);
  const uint32_t n = 5000, leaf = 4;
  const auto keys = sorted_keys(n, 99, true);
  for (uint32_t max_level : {1u, 3u, 6u}) {
    CAPTURE(max_level);
    const auto want = ref::build_octree(keys, leaf, max_level);
    const auto full = ref::build_octree(keys, leaf);
    gpu::Buffer<uint64_t> k(ctx, keys, "keys");
    gpu::Buffer<glm::uvec4> nodes(ctx, octree::OctreeBuild::node_capacity(n, leaf), "nodes");
    gpu::Buffer<glm::uvec2> info(ctx, 22, "level info");
    gpu::Sequence seq(ctx);
    build.record(seq, k, n, leaf, nodes, info, max_level);
    seq.submit_and_wait();
    REQUIRE(info.download() == want.level_info);
    CHECK(nodes.download(0, want.nodes.size()) == want.nodes);
    // The levels up to the cap are the full tree's; below it there is nothing, and every particle is in a leaf.
    for (uint32_t l = 0; l <= max_level; ++l) CHECK(want.level_info[l].y == full.level_info[l].y);
    for (uint32_t l = max_level + 1; l < 22; ++l) CHECK(want.level_info[l].y == 0);
    uint32_t in_leaves = 0, crowded = 0;
    for (const auto& node : want.nodes)
      if ((node.w & 0xffu) == 0) {
        in_leaves += node.y;
        crowded += node.y > leaf;
      }
    CHECK(in_leaves == n);
    CHECK(crowded > 0);  // clustered keys: the cap leaves some leaves fuller than leaf_size
  }
}

TEST_CASE_FIXTURE(GpuFixture, "GPU octree matches the reference") {
  octree::OctreeBuild build(ctx);
  for (uint32_t n : {0u, 1u, 17u, 1000u, 70000u}) {
    for (uint32_t leaf : {1u, 16u}) {
      for (bool clustered : {false, true}) {
        CAPTURE(n);
        CAPTURE(leaf);
        CAPTURE(clustered);
        const auto keys = sorted_keys(n, n + leaf, clustered);
        const auto want = ref::build_octree(keys, leaf);
        gpu::Buffer<uint64_t> k(ctx, keys, "keys");
        gpu::Buffer<glm::uvec4> nodes(ctx, octree::OctreeBuild::node_capacity(n, leaf), "nodes");
        gpu::Buffer<glm::uvec2> info(ctx, 22, "level info");
        gpu::Sequence seq(ctx);
        build.record(seq, k, n, leaf, nodes, info);
        seq.submit_and_wait();
        const auto got_info = info.download();
        REQUIRE(got_info == want.level_info);
        const auto total = want.nodes.size();
        REQUIRE(total <= nodes.size());
        CHECK(nodes.download(0, total) == want.nodes);
      }
    }
  }
}

TEST_CASE_FIXTURE(GpuFixture, "GPU octree of particles: Morton sort, build and moments match the references") {
  octree::MortonSort sorter(ctx);
  octree::OctreeBuild build(ctx);
  bool exact_sets = true;
  SUBCASE("material slots intersected") {}
  SUBCASE("masks only") { exact_sets = false; }
  const octree::OctreeMoments moments(ctx, exact_sets);
  for (uint32_t n : {1u, 300u, 50000u}) {
    CAPTURE(n);
    std::mt19937 rng(n * 7);
    std::uniform_real_distribution<float> u(0.0f, 50.0f), hs(0.5f, 2.0f);
    std::vector<glm::vec4> particles(n);
    for (auto& p : particles) p = glm::vec4(u(rng), u(rng), 0.3f * u(rng), hs(rng));
    const uint32_t leaf = 16;
    const auto box = octree::MortonBox::around(glm::vec3(0.0f), glm::vec3(50.0f));
    gpu::Buffer<glm::vec4> pb(ctx, particles, "particles");
    gpu::Buffer<uint64_t> keys(ctx, n, "keys");
    gpu::Buffer<uint32_t> order(ctx, n, "order");
    const size_t capacity = octree::OctreeBuild::node_capacity(n, leaf);
    gpu::Buffer<glm::uvec4> nodes(ctx, capacity, "nodes");
    gpu::Buffer<glm::uvec2> info(ctx, 22, "level info");
    octree::NodeMoments m(ctx, capacity);
    // Material sets that share only 700, then random ones with 700 and ids whose halves differ in one byte or bit.
    std::vector<fields::MaterialSet> masks = {{5, 700}, {5, 700, 9000}, {700, 9000}};
    const uint16_t pool[] = {0, 1, 5, 0x100, 0x101, 0x7fff, 0x8000, 0x8001, 0xfffe, 9000};
    while (masks.size() < 12) {
      std::vector<uint16_t> m = {700};
      for (uint32_t k = 1 + rng() % 3; k > 0; --k) m.push_back(pool[rng() % std::size(pool)]);
      std::shuffle(m.begin(), m.end(), rng);
      masks.emplace_back(m);
    }
    std::vector<uint32_t> features(n);
    for (uint32_t i = 0; i < n; ++i) features[i] = i < 3 ? i : uint32_t(rng() % masks.size());
    gpu::Buffer<glm::uvec4> pm(ctx, octree::particle_masks(features, masks), "particle masks");
    gpu::Sequence seq(ctx);
    sorter.record(seq, pb, box, keys, order, n);
    build.record(seq, keys, n, leaf, nodes, info);
    moments.record(seq, nodes, info, order, pb, pm, m, n);
    seq.submit_and_wait();

    const auto tree = ref::build_octree(keys.download(), leaf);
    const auto got_order = order.download();
    const auto want = ref::octree_moments(tree, got_order, particles, features, masks, exact_sets);
    std::vector<glm::vec4> got(want.size());  // interleaved like the reference: lo, hi, com, mask per node
    {
      const size_t nodes_used = want.size() / 4;
      const auto lo = m.lo.download(0, nodes_used), hi = m.hi.download(0, nodes_used),
                 com = m.com.download(0, nodes_used), mask = m.and_mask.download(0, nodes_used);
      for (size_t i = 0; i < nodes_used; ++i) {
        got[4 * i] = lo[i];
        got[4 * i + 1] = hi[i];
        got[4 * i + 2] = com[i];
        got[4 * i + 3] = mask[i];
      }
    }
    REQUIRE(info.download() == tree.level_info);
    float worst = 0;
    for (size_t i = 0; i < want.size(); ++i) {
      if (i % 4 == 3) {  // the material masks and sets, exactly
        CHECK(glm::floatBitsToUint(got[i]) == glm::floatBitsToUint(want[i]));
        continue;
      }
      worst = std::max(worst, glm::length(got[i] - want[i]));
    }
    CHECK(worst <= 1e-4f * 50.0f);
    // The root holds every particle: its box and count are those of the input.
    glm::vec3 lo(1e30f), hi(-1e30f);
    float min_h = 1e30f;
    for (const auto& p : particles) {
      lo = glm::min(lo, glm::vec3(p));
      hi = glm::max(hi, glm::vec3(p));
      min_h = std::min(min_h, p.w);
    }
    CHECK(got[0] == glm::vec4(lo, min_h));
    CHECK(glm::vec3(got[1]) == hi);
    CHECK(got[2].w == float(n));
    // The intersection of the sets: the root's is what all three features share (material 700), a leaf of one
    // feature its own.
    const glm::uvec4 root = glm::floatBitsToUint(got[3]);
    const uint64_t root_mask = uint64_t(root.x) | uint64_t(root.y) << 32;
    CHECK((root_mask >> (700 % 64) & 1) == 1);
    if (exact_sets) {
      const auto set = fields::MaterialSet::from_packed(uint64_t(root.z) | uint64_t(root.w) << 32);
      CHECK(set.members() == (n >= 3 ? std::vector<uint16_t>{700} : masks[0].members()));
    } else {
      CHECK(root.z == 0u);
    }
  }
}
