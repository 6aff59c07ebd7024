// shaders/morton_codes.comp and the Morton sort against ref::morton_codes and a stable sort.
#include <doctest/doctest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include "gpu_fixture.h"
#include "octree/morton.h"
#include "ref/morton_codes.h"

using namespace cpmesh;
using cpmesh::test::GpuFixture;

TEST_CASE("Morton keys interleave x, y, z from the least significant bit") {
  const glm::vec3 lo(0.0f), scale(1.0f);
  CHECK(ref::morton_code({1, 0, 0}, lo, scale) == 1u);
  CHECK(ref::morton_code({0, 1, 0}, lo, scale) == 2u);
  CHECK(ref::morton_code({0, 0, 1}, lo, scale) == 4u);
  CHECK(ref::morton_code({3, 0, 0}, lo, scale) == 9u);
  const uint64_t top = ref::morton_code({2097151, 2097151, 2097151}, lo, scale);
  CHECK(top == (uint64_t(1) << 63) - 1);
  CHECK(ref::morton_code({-5, 1e9f, 0}, lo, scale) == ref::morton_code({0, 2097151, 0}, lo, scale));  // clamped
}

TEST_CASE_FIXTURE(GpuFixture, "GPU Morton keys match the reference bit for bit, and the sort orders the particles") {
  octree::MortonSort sorter(ctx);
  for (uint32_t n : {0u, 1u, 255u, 257u, 5000u, 100000u}) {
    CAPTURE(n);
    std::mt19937 rng(n);
    std::uniform_real_distribution<float> u(-2.0f, 66.0f);  // some outside the box: clamped
    std::vector<glm::vec4> pos(n);
    for (auto& p : pos) p = glm::vec4(u(rng), u(rng), u(rng), 0.0f);
    if (n > 10) pos[3] = pos[7];  // duplicates keep their order
    const auto box = octree::MortonBox::around(glm::vec3(0.0f), glm::vec3(64.0f));
    gpu::Buffer<glm::vec4> positions(ctx, pos, "positions");
    gpu::Buffer<uint64_t> keys(ctx, n, "keys");
    gpu::Buffer<uint32_t> indices(ctx, n, "indices");
    gpu::Sequence seq(ctx);
    sorter.record(seq, positions, box, keys, indices, n);
    seq.submit_and_wait();
    auto want_keys = ref::morton_codes(pos, box.min, box.scale);
    std::vector<uint32_t> want_idx(n);
    std::iota(want_idx.begin(), want_idx.end(), 0u);
    std::stable_sort(want_idx.begin(), want_idx.end(), [&](uint32_t a, uint32_t b) { return want_keys[a] < want_keys[b]; });
    std::vector<uint64_t> sorted(n);
    for (uint32_t i = 0; i < n; ++i) sorted[i] = want_keys[want_idx[i]];
    CHECK(keys.download() == sorted);
    CHECK(indices.download() == want_idx);
  }
}
