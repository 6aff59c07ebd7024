// Every building-block shader against its C++ reference (ref/primitives.h), at edge sizes and at sizes where a loop
// over the whole input in one invocation would pass lavapipe's ~65k-iteration limit (LAVAPIPE.md, pitfall 1).
#include <doctest/doctest.h>

#include <cmath>
#include <limits>

#include "gpu_fixture.h"
#include "primitives/compact.h"
#include "primitives/radix_sort.h"
#include "primitives/reduce.h"
#include "ref/primitives.h"

using namespace cpmesh;
using cpmesh::test::GpuFixture;

namespace {

std::vector<uint32_t> gpu_scan(gpu::Context& ctx, const std::vector<uint32_t>& data, bool as_flags, bool in_place,
                               uint32_t* total) {
  const uint32_t n = uint32_t(data.size());
  gpu::Buffer<uint32_t> src(ctx, data, "scan src"), dst(ctx, n, "scan dst"),
      t(ctx, 2, "scan total", gpu::MemoryUse::readback);
  t.upload(std::vector<uint32_t>{0xabcdu, 0xabcdu});
  gpu::Scan scan(ctx);
  gpu::Sequence seq(ctx);
  scan.record(seq, src, in_place ? src : dst, n, as_flags, &t, 1);
  seq.submit_and_wait();
  CHECK(t.read(0) == 0xabcdu);  // only total[1] is written
  *total = t.read(1);
  return (in_place ? src : dst).download();
}

}  // namespace

TEST_CASE_FIXTURE(GpuFixture, "exclusive scan matches the reference") {
  auto sizes = test::edge_sizes();
  sizes.push_back(1u << 20);          // two levels of block sums
  sizes.push_back((1u << 20) + 1025);  // three levels
  for (uint32_t n : sizes) {
    CAPTURE(n);
    const auto data = test::random_u32(n, n + 1, 1000);
    uint32_t total = 0;
    const auto want = ref::exclusive_scan(data);
    CHECK(gpu_scan(ctx, data, false, false, &total) == want);
    CHECK(total == (n ? want.back() + data.back() : 0u));
    CHECK(gpu_scan(ctx, data, false, true, &total) == want);
  }
}

TEST_CASE_FIXTURE(GpuFixture, "scan wraps modulo 2^32 and counts flags") {
  const auto data = test::random_u32(100000, 77);  // full-range values: sums overflow many times
  uint32_t total = 0;
  CHECK(gpu_scan(ctx, data, false, false, &total) == ref::exclusive_scan(data));
  const auto flags = test::random_u32(100000, 78, 4);  // 0..3: counted as 0/1
  CHECK(gpu_scan(ctx, flags, true, false, &total) == ref::exclusive_scan(flags, true));
  const auto want = ref::exclusive_scan(flags, true);
  CHECK(total == want.back() + (flags.back() != 0));
}

TEST_CASE_FIXTURE(GpuFixture, "reductions match the reference") {
  gpu::Reduce reduce(ctx);
  auto sizes = test::edge_sizes();
  sizes.push_back(2048 * 2048 + 3);  // three passes
  for (uint32_t n : sizes) {
    CAPTURE(n);
    std::mt19937_64 rng(n);
    std::vector<float> f(n);
    double abs_sum = 0;
    for (auto& x : f) {
      x = float(std::uniform_real_distribution<double>(-100.0, 100.0)(rng));
      abs_sum += std::fabs(x);
    }
    const auto u = test::random_u32(n, n + 7);
    gpu::Buffer<float> fsrc(ctx, f, "f"), fout(ctx, 4, "fout", gpu::MemoryUse::readback);
    gpu::Buffer<uint32_t> usrc(ctx, u, "u"), uout(ctx, 4, "uout", gpu::MemoryUse::readback);
    gpu::Sequence seq(ctx);
    for (uint32_t op = 0; op < 3; ++op) {
      reduce.record(seq, gpu::ReduceOp(op), fsrc, n, fout, op + 1);
      reduce.record(seq, gpu::ReduceOp(op), usrc, n, uout, op + 1);
    }
    seq.submit_and_wait();
    const auto fg = fout.download();
    const auto ug = uout.download();
    // Float sums: tree order vs. a double accumulation; the bound is float rounding over log2(n) levels.
    CHECK(std::fabs(fg[1] - ref::reduce(std::span<const float>(f), 0)) <= 1e-6 * abs_sum * 24 + 1e-6);
    CHECK(fg[2] == float(ref::reduce(std::span<const float>(f), 1)));
    CHECK(fg[3] == float(ref::reduce(std::span<const float>(f), 2)));
    for (uint32_t op = 0; op < 3; ++op) CHECK(ug[op + 1] == ref::reduce(std::span<const uint32_t>(u), op));
  }
}

TEST_CASE_FIXTURE(GpuFixture, "reductions of equal values and of the empty array") {
  gpu::Reduce reduce(ctx);
  const uint32_t n = 70000;
  gpu::Buffer<float> ones(ctx, std::vector<float>(n, 0.5f), "halves"), out(ctx, 3, "out", gpu::MemoryUse::readback);
  gpu::Buffer<float> empty(ctx, size_t(0), "empty"), eout(ctx, 3, "eout", gpu::MemoryUse::readback);
  gpu::Sequence seq(ctx);
  for (uint32_t op = 0; op < 3; ++op) {
    reduce.record(seq, gpu::ReduceOp(op), ones, n, out, op);
    reduce.record(seq, gpu::ReduceOp(op), empty, 0, eout, op);
  }
  seq.submit_and_wait();
  CHECK(out.download() == std::vector<float>{35000.0f, 0.5f, 0.5f});
  const auto e = eout.download();
  CHECK(e[0] == 0.0f);
  CHECK(e[1] == std::numeric_limits<float>::infinity());
  CHECK(e[2] == -std::numeric_limits<float>::infinity());
}

TEST_CASE_FIXTURE(GpuFixture, "stream compaction matches the reference") {
  gpu::Compact compact(ctx);
  auto sizes = test::edge_sizes();
  sizes.push_back(1u << 20);
  for (uint32_t n : sizes) {
    for (uint32_t density : {0u, 1u, 3u, 100u}) {  // no flags, all flags, about 1/3, about 1/100 (as 1-in-k)
      CAPTURE(n);
      CAPTURE(density);
      std::vector<uint32_t> flags(n);
      std::mt19937_64 rng(n * 31 + density);
      for (auto& f : flags) f = density == 0 ? 0u : (density == 1 ? 7u : uint32_t(rng() % density == 0) * 2u);
      const auto values = test::random_u32(n, n + 3);
      gpu::Buffer<uint32_t> fl(ctx, flags, "flags"), vals(ctx, values, "values"), out(ctx, n, "out"),
          out_idx(ctx, n, "out indices"), count(ctx, 2, "count", gpu::MemoryUse::readback);
      gpu::Sequence seq(ctx);
      compact.record(seq, fl, vals, n, out, count, 0);
      compact.record_indices(seq, fl, n, out_idx, count, 1);
      seq.submit_and_wait();
      const auto want = ref::compact(flags, values);
      const auto want_idx = ref::compact(flags, {});
      const auto c = count.download();
      REQUIRE(c[0] == want.size());
      REQUIRE(c[1] == want.size());
      CHECK(out.download(0, c[0]) == want);
      CHECK(out_idx.download(0, c[1]) == want_idx);
    }
  }
}

TEST_CASE_FIXTURE(GpuFixture, "radix sort of 32-bit keys with payload matches a stable sort") {
  gpu::RadixSort sort(ctx);
  struct Case {
    uint32_t n, key_bits, modulo;
  };
  std::vector<Case> cases;
  for (uint32_t n : test::edge_sizes()) cases.push_back({n, 32, 0});
  cases.push_back({1u << 20, 32, 0});   // the 1M-pair sort
  cases.push_back({100000, 32, 16});    // many duplicates: stability shows
  cases.push_back({100000, 32, 1});     // all equal
  cases.push_back({100000, 12, 0});     // 3 passes (odd: result copied back), upper bits ignored
  cases.push_back({100000, 30, 0});     // Morton-code width
  for (const auto& c : cases) {
    CAPTURE(c.n);
    CAPTURE(c.key_bits);
    CAPTURE(c.modulo);
    auto keys = test::random_u32(c.n, c.n * 3 + c.key_bits, c.modulo);
    std::vector<uint32_t> values(c.n);
    for (uint32_t i = 0; i < c.n; ++i) values[i] = i;
    gpu::Buffer<uint32_t> k(ctx, keys, "keys"), v(ctx, values, "values");
    gpu::Sequence seq(ctx);
    sort.record(seq, k, v, c.n, c.key_bits);
    seq.submit_and_wait();
    ref::radix_sort(keys, values, c.key_bits);
    CHECK(k.download() == keys);
    CHECK(v.download() == values);
  }
}

TEST_CASE_FIXTURE(GpuFixture, "radix sort by a bit range of 64-bit keys (the top of Morton codes) matches a stable sort") {
  gpu::RadixSort sort(ctx);
  for (uint32_t n : {1000u, 70000u}) {
    for (uint32_t first_bit : {36u, 42u, 45u}) {  // depth caps 9, 7, 6 of 63-bit keys: 27, 21, 18 bits sorted
      const uint32_t key_bits = 63 - first_bit;
      CAPTURE(n);
      CAPTURE(first_bit);
      std::mt19937_64 rng(n + first_bit);
      std::vector<uint64_t> keys(n);
      for (auto& x : keys) x = rng() >> 1;
      std::vector<uint32_t> values(n);
      for (uint32_t i = 0; i < n; ++i) values[i] = i;
      gpu::Buffer<uint64_t> k(ctx, keys, "keys64");
      gpu::Buffer<uint32_t> v(ctx, values, "values");
      gpu::Sequence seq(ctx);
      sort.record(seq, k, v, n, key_bits, first_bit);
      seq.submit_and_wait();
      ref::radix_sort(keys, values, key_bits, first_bit);
      CHECK(k.download() == keys);
      CHECK(v.download() == values);
      // Sorted by the top bits, and stable below them: the low bits are not in order.
      bool low_unsorted = false;
      for (uint32_t i = 1; i < n; ++i) {
        CHECK((keys[i - 1] >> first_bit) <= (keys[i] >> first_bit));
        low_unsorted |= (keys[i - 1] >> first_bit) == (keys[i] >> first_bit) && keys[i - 1] > keys[i];
      }
      if (n == 70000 && first_bit == 45) CHECK(low_unsorted);
    }
  }
  gpu::Buffer<uint64_t> k(ctx, 4, "keys64");
  gpu::Buffer<uint32_t> v(ctx, 4, "values");
  gpu::Sequence seq(ctx);
  CHECK_THROWS_AS(sort.record(seq, k, v, 4, 30, 40), gpu::Error);
}

TEST_CASE_FIXTURE(GpuFixture, "radix sort of 64-bit keys with payload matches a stable sort") {
  gpu::RadixSort sort(ctx);
  for (uint32_t n : {0u, 1u, 1000u, 1025u, 300000u}) {
    for (uint32_t key_bits : {64u, 63u, 36u}) {
      CAPTURE(n);
      CAPTURE(key_bits);
      std::mt19937_64 rng(n + key_bits);
      std::vector<uint64_t> keys(n);
      for (auto& x : keys) x = key_bits == 36 ? (rng() % 64) << 30 | (rng() & 0xff) : rng();  // duplicates in bits 30+
      std::vector<uint32_t> values(n);
      for (uint32_t i = 0; i < n; ++i) values[i] = i;
      gpu::Buffer<uint64_t> k(ctx, keys, "keys64");
      gpu::Buffer<uint32_t> v(ctx, values, "values");
      gpu::Sequence seq(ctx);
      sort.record(seq, k, v, n, key_bits);
      seq.submit_and_wait();
      ref::radix_sort(keys, values, key_bits);
      CHECK(k.download() == keys);
      CHECK(v.download() == values);
    }
  }
}
