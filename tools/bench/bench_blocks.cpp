// Micro-benchmark of the GPU building blocks: radix sort (32- and 64-bit keys with payload), exclusive scan,
// reduction and compaction, in keys/s on the chosen device and in the C++ reference, side by side.
// Every GPU result is checked against the reference before it is timed. Prints a table and one JSON line.
//   cpmesh-bench-blocks [--device D] [--sizes 1048576,4194304] [--repeat 3]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <iostream>
#include <random>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "gpu/describe.h"
#include "primitives/compact.h"
#include "primitives/radix_sort.h"
#include "primitives/reduce.h"
#include "ref/primitives.h"

using namespace cpmesh;

namespace {

double best_ms(int repeat, const std::function<void()>& setup, const std::function<void()>& run) {
  double best = 1e300;
  for (int r = 0; r < repeat; ++r) {
    setup();
    const auto t0 = std::chrono::steady_clock::now();
    run();
    best = std::min(best, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  return best;
}

struct Row {
  std::string op;
  uint32_t n;
  double gpu_ms, ref_ms;
  bool verified;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Benchmark of the GPU building blocks (sort, scan, reduce, compact) against their C++ references"};
  std::string device;
  std::vector<uint32_t> sizes = {1u << 20, 1u << 22};
  int repeat = 3;
  app.add_option("--device", device, "Vulkan device index or name substring (see `cpmesh devices`)");
  app.add_option("--sizes", sizes, "Element counts")->delimiter(',')->capture_default_str();
  app.add_option("--repeat", repeat, "Timed repetitions (best is reported)")->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);

  try {
    gpu::Context ctx(gpu::ContextOptions{device, false, false});
    gpu::Scan scan(ctx);
    gpu::Reduce reduce(ctx);
    gpu::Compact compact(ctx);
    gpu::RadixSort sort(ctx);
    std::vector<Row> rows;
    for (uint32_t n : sizes) {
      std::mt19937_64 rng(n);
      std::vector<uint32_t> keys(n), idx(n), flags(n);
      std::vector<uint64_t> keys64(n);
      std::vector<float> f(n);
      for (uint32_t i = 0; i < n; ++i) {
        keys[i] = uint32_t(rng());
        keys64[i] = rng();
        idx[i] = i;
        flags[i] = uint32_t(rng() % 4 == 0);
        f[i] = float(rng() % 1000) * 0.001f;
      }
      gpu::Buffer<uint32_t> k(ctx, n, "keys"), v(ctx, n, "values"), fl(ctx, flags, "flags"), out(ctx, n, "out"),
          count(ctx, 1, "count", gpu::MemoryUse::readback);
      gpu::Buffer<uint64_t> k64(ctx, n, "keys64");
      gpu::Buffer<float> fb(ctx, f, "floats"), fsum(ctx, 1, "sum", gpu::MemoryUse::readback);

      auto run = [&](const std::function<void(gpu::Sequence&)>& record) {
        gpu::Sequence seq(ctx);
        record(seq);
        seq.submit_and_wait();
      };

      auto bench_sort = [&](const char* name, const auto& keys_in, auto& key_buffer) {
        auto upload = [&] { key_buffer.upload(keys_in); v.upload(idx); };
        auto rk = keys_in;
        auto rv = idx;
        upload();
        run([&](gpu::Sequence& s) { sort.record(s, key_buffer, v, n); });
        const double ref_ms = best_ms(1, [&] { rk = keys_in; rv = idx; }, [&] { ref::radix_sort(rk, rv); });
        const bool ok = key_buffer.download() == rk && v.download() == rv;
        const double gpu_ms =
            best_ms(repeat, upload, [&] { run([&](gpu::Sequence& s) { sort.record(s, key_buffer, v, n); }); });
        rows.push_back({name, n, gpu_ms, ref_ms, ok});
      };
      bench_sort("radix_sort u32+payload", keys, k);
      bench_sort("radix_sort u64+payload", keys64, k64);
      {  // scan
        std::vector<uint32_t> want;
        const double ref_ms = best_ms(repeat, [] {}, [&] { want = ref::exclusive_scan(idx); });
        v.upload(idx);
        run([&](gpu::Sequence& s) { scan.record(s, v, out, n); });
        const bool ok = out.download() == want;
        const double gpu_ms = best_ms(repeat, [] {}, [&] { run([&](gpu::Sequence& s) { scan.record(s, v, out, n); }); });
        rows.push_back({"exclusive_scan u32", n, gpu_ms, ref_ms, ok});
      }
      {  // reduce
        double want = 0;
        const double ref_ms = best_ms(repeat, [] {}, [&] { want = ref::reduce(std::span<const float>(f), 0); });
        run([&](gpu::Sequence& s) { reduce.record(s, gpu::ReduceOp::sum, fb, n, fsum); });
        const bool ok = std::abs(fsum.read(0) - want) <= 1e-5 * want + 1e-3;
        const double gpu_ms = best_ms(repeat, [] {}, [&] {
          run([&](gpu::Sequence& s) { reduce.record(s, gpu::ReduceOp::sum, fb, n, fsum); });
        });
        rows.push_back({"reduce sum f32", n, gpu_ms, ref_ms, ok});
      }
      {  // compact
        std::vector<uint32_t> want;
        const double ref_ms = best_ms(repeat, [] {}, [&] { want = ref::compact(flags, {}); });
        run([&](gpu::Sequence& s) { compact.record_indices(s, fl, n, out, count); });
        const bool ok = count.read(0) == want.size() && out.download(0, want.size()) == want;
        const double gpu_ms = best_ms(repeat, [] {}, [&] {
          run([&](gpu::Sequence& s) { compact.record_indices(s, fl, n, out, count); });
        });
        rows.push_back({"compact (1 in 4)", n, gpu_ms, ref_ms, ok});
      }
    }

    std::printf("Building blocks on %s (best of %d; GPU time includes submit and wait, not uploads)\n",
                ctx.info().name.c_str(), repeat);
    std::printf("%-24s %10s %12s %14s %12s %14s %8s %s\n", "operation", "n", "gpu ms", "gpu Mkeys/s", "ref ms",
                "ref Mkeys/s", "gpu/ref", "check");
    nlohmann::json j = {{"benchmark", "building_blocks"}, {"device", ctx.info().name}, {"repeat", repeat},
                        {"results", nlohmann::json::array()}};
    bool all_ok = true;
    for (const auto& r : rows) {
      const double g = r.n / r.gpu_ms / 1e3, c = r.n / r.ref_ms / 1e3;
      std::printf("%-24s %10u %12.2f %14.1f %12.2f %14.1f %8.2f %s\n", r.op.c_str(), r.n, r.gpu_ms, g, r.ref_ms, c,
                  g / c, r.verified ? "ok" : "MISMATCH");
      j["results"].push_back({{"op", r.op}, {"n", r.n}, {"gpu_ms", r.gpu_ms}, {"ref_ms", r.ref_ms},
                              {"gpu_mkeys_per_s", g}, {"ref_mkeys_per_s", c}, {"verified", r.verified}});
      all_ok = all_ok && r.verified;
    }
    std::cout << j.dump() << '\n';
    return all_ok ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "cpmesh-bench-blocks: error: " << e.what() << '\n';
    return 1;
  }
}
