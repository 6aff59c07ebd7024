#include "primitives/selftest.h"

#include <chrono>
#include <type_traits>
#include <cmath>
#include <random>

#include "primitives/compact.h"
#include "primitives/radix_sort.h"
#include "primitives/reduce.h"
#include "ref/primitives.h"

namespace cpmesh::gpu {

namespace {

template <class T>
std::string first_mismatch(const std::vector<T>& got, const std::vector<T>& want) {
  if (got.size() != want.size())
    return "size " + std::to_string(got.size()) + ", expected " + std::to_string(want.size());
  for (size_t i = 0; i < got.size(); ++i)
    if (got[i] != want[i])
      return "index " + std::to_string(i) + ": " + std::to_string(got[i]) + ", expected " + std::to_string(want[i]);
  return {};
}

template <class F>
double timed(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

std::vector<SelftestResult> run_selftest(Context& ctx, uint32_t n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<uint32_t> u(n), flags(n);
  std::vector<uint64_t> u64(n);
  std::vector<float> f(n);
  for (uint32_t i = 0; i < n; ++i) {
    u[i] = uint32_t(rng());
    u64[i] = rng();
    flags[i] = uint32_t(rng() % 3 == 0) * uint32_t(1 + rng() % 5);
    f[i] = float(std::uniform_real_distribution<double>(-1.0, 1.0)(rng));
  }
  std::vector<SelftestResult> out;

  {  // scan
    Scan scan(ctx);
    std::vector<uint32_t> small(n);
    for (uint32_t i = 0; i < n; ++i) small[i] = u[i] % 1000;
    Buffer<uint32_t> src(ctx, small, "selftest scan"), dst(ctx, n, "selftest scan out");
    SelftestResult r{"exclusive_scan", n, false, {}, 0};
    r.ms = timed([&] {
      Sequence seq(ctx);
      scan.record(seq, src, dst, n);
      seq.submit_and_wait();
    });
    r.detail = first_mismatch(dst.download(), ref::exclusive_scan(small));
    r.passed = r.detail.empty();
    out.push_back(r);
  }
  {  // reductions
    Reduce reduce(ctx);
    Buffer<float> fsrc(ctx, f, "selftest reduce f32"), fout(ctx, 3, "selftest reduce f32 out", MemoryUse::readback);
    Buffer<uint32_t> usrc(ctx, u, "selftest reduce u32"), uout(ctx, 3, "selftest reduce u32 out", MemoryUse::readback);
    const double ms = timed([&] {
      Sequence seq(ctx);
      for (uint32_t op = 0; op < 3; ++op) {
        reduce.record(seq, ReduceOp(op), fsrc, n, fout, op);
        reduce.record(seq, ReduceOp(op), usrc, n, uout, op);
      }
      seq.submit_and_wait();
    });
    const char* names[3] = {"sum", "min", "max"};
    const auto fg = fout.download();
    const auto ug = uout.download();
    double abs_sum = 0;
    for (float x : f) abs_sum += std::fabs(x);
    for (uint32_t op = 0; op < 3; ++op) {
      const double want = ref::reduce(std::span<const float>(f), op);
      const double tol = op == 0 ? 1e-5 * abs_sum + 1e-6 : 0.0;
      SelftestResult rf{std::string("reduce_f32 ") + names[op], n, std::fabs(fg[op] - want) <= tol, {}, ms / 6};
      if (!rf.passed) rf.detail = std::to_string(fg[op]) + ", expected " + std::to_string(want);
      out.push_back(rf);
      const uint32_t uwant = ref::reduce(std::span<const uint32_t>(u), op);
      SelftestResult ru{std::string("reduce_u32 ") + names[op], n, ug[op] == uwant, {}, ms / 6};
      if (!ru.passed) ru.detail = std::to_string(ug[op]) + ", expected " + std::to_string(uwant);
      out.push_back(ru);
    }
  }
  {  // compaction
    Compact compact(ctx);
    Buffer<uint32_t> fl(ctx, flags, "selftest flags"), vals(ctx, u, "selftest values"), dst(ctx, n, "selftest compacted"),
        count(ctx, 1, "selftest count", MemoryUse::readback);
    SelftestResult r{"compact", n, false, {}, 0};
    r.ms = timed([&] {
      Sequence seq(ctx);
      compact.record(seq, fl, vals, n, dst, count);
      seq.submit_and_wait();
    });
    const auto want = ref::compact(flags, u);
    const uint32_t got_count = count.read(0);
    r.detail = got_count != want.size() ? "count " + std::to_string(got_count) + ", expected " + std::to_string(want.size())
                                        : first_mismatch(dst.download(0, got_count), want);
    r.passed = r.detail.empty();
    out.push_back(r);
  }
  {  // radix sorts
    RadixSort sort(ctx);
    std::vector<uint32_t> idx(n);
    for (uint32_t i = 0; i < n; ++i) idx[i] = i;
    auto check_sort = [&](const char* name, const auto& keys_in) {
      Buffer<typename std::decay_t<decltype(keys_in)>::value_type> keys(ctx, keys_in, "selftest keys");
      Buffer<uint32_t> vals(ctx, idx, "selftest payload");
      SelftestResult r{name, n, false, {}, 0};
      r.ms = timed([&] {
        Sequence seq(ctx);
        sort.record(seq, keys, vals, n);
        seq.submit_and_wait();
      });
      auto k = keys_in;
      auto v = idx;
      ref::radix_sort(k, v);
      r.detail = first_mismatch(keys.download(), k);
      if (r.detail.empty()) r.detail = first_mismatch(vals.download(), v);
      r.passed = r.detail.empty();
      out.push_back(r);
    };
    check_sort("radix_sort u32", u);
    check_sort("radix_sort u64", u64);
  }
  return out;
}

}  // namespace cpmesh::gpu
