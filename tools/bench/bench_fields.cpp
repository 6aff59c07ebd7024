// Benchmark of the fields stage (indicator fields, closest point embedding, sizing field) on synthetic volumes, and
// of the closest point lookup on the device against its C++ reference. Prints a table and one JSON line per volume.
//   cpmesh-bench-fields [--device D] [--volumes wedge-ball:128,shells:256] [--lookups 1048576]
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <cstdio>
#include <iostream>
#include <random>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "fields/cp_lookup_gpu.h"
#include "fields/fields_stage.h"
#include "ref/cp_lookup.h"
#include "fields/volume_grid.h"
#include "io/synth_volumes.h"
#include "bench_util.h"

using namespace cpmesh;
using bench::peak_rss_mib;

namespace {

double seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Benchmark of the fields stage and the closest point lookup"};
  std::string device;
  std::vector<std::string> volumes = {"wedge-ball:128", "shells:256"};
  uint32_t lookups = 1u << 20;
  app.add_option("--device", device, "Vulkan device index or name substring");
  app.add_option("--volumes", volumes, "shape:size, shape = sphere, wedge-ball, slabs or shells; or onion:size:labels (concentric shells)")->delimiter(',')->capture_default_str();
  app.add_option("--lookups", lookups, "Closest point lookups timed on the device and in the reference")->capture_default_str();
  bool indicator_only = false;
  app.add_flag("--indicator-only", indicator_only, "Only the indicator fields (memory check for large volumes)");
  CLI11_PARSE(app, argc, argv);
  try {
    gpu::Context ctx(gpu::ContextOptions{device, false, false});
    fields::CpLookup lookup(ctx);
    std::printf("%-16s %9s %9s %9s %9s %10s %10s %9s %12s %12s %8s\n", "volume", "indic s", "embed s", "sizing s",
                "total s", "fields MiB", "embed MiB", "rss MiB", "gpu Mlook/s", "ref Mlook/s", "max diff");
    for (const auto& spec : volumes) {
      const auto colon = spec.find(':');
      const std::string kind = spec.substr(0, colon);
      const int n = std::stoi(spec.substr(colon + 1));
      io::SynthVolume vol;
      if (kind.rfind("onion", 0) == 0) {
        // Memory check with many labels: concentric shells onion:SIZE:LABELS (labels - 1 spheres, evenly spaced radii).
        const auto second = spec.find(':', colon + 1);
        const int labels = second == std::string::npos ? 10 : std::stoi(spec.substr(second + 1));
        vol.volume.dims = {n, n, n};
        vol.volume.labels.resize(size_t(n) * n * n);
        const double c = (n - 1) / 2.0 + 0.13, rmax = 0.47 * n;
        for (int k = 0; k < n; ++k)
          for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
              const double r = std::sqrt((i - c) * (i - c) + (j - c) * (j - c) + (k - c) * (k - c));
              vol.volume.labels[(size_t(k) * n + j) * n + i] = uint16_t(r >= rmax ? 0 : labels - 1 - int(r / rmax * (labels - 1)));
            }
      } else {
        io::SynthOptions so;
        so.shape = io::parse_synth_shape(kind);
        so.size = n;
        vol = io::make_synth_volume(so);
      }
      if (indicator_only) {
        const auto ti = std::chrono::steady_clock::now();
        const auto F = fields::build_indicator_fields(fields::grid_of(vol.volume), vol.volume.labels.data());
        const double s = seconds(ti);
        std::printf("%-16s indicator fields of %zu materials: %.2f s, %.1f MiB stored (dense would be %.1f MiB), peak RSS %.0f MiB\n",
                    spec.c_str(), F.material_count(), s, double(F.memory_bytes()) / 1048576.0,
                    double(F.material_count()) * double(vol.volume.labels.size()) * 4.0 / 1048576.0, peak_rss_mib());
        std::cout << nlohmann::json{{"benchmark", "indicator_fields"}, {"volume", spec}, {"materials", F.material_count()},
                                    {"seconds", s}, {"bytes", F.memory_bytes()}, {"peak_rss_mib", peak_rss_mib()}}.dump()
                  << '\n';
        continue;
      }
      const auto t0 = std::chrono::steady_clock::now();
      auto r = fields::build_fields(fields::grid_of(vol.volume), vol.volume.labels.data());
      const double total = seconds(t0);

      // Lookup queries: jittered closest points of random blocks, each with its block's feature.
      const auto& E = r.embedding;
      std::mt19937 rng(5);
      std::uniform_real_distribution<float> jitter(-0.5f, 0.5f);
      std::vector<glm::vec4> queries(lookups);
      std::vector<size_t> used_slots;
      for (size_t s = 0; s < E.keys.size(); ++s)
        if (E.keys[s] != fields::ClosestPointEmbedding::kEmpty) used_slots.push_back(s);
      for (auto& q : queries) {
        const size_t s = used_slots[rng() % used_slots.size()];
        const glm::vec3 cp(E.fine[size_t(E.blocks[s]) * 8]);
        q = glm::vec4(cp + glm::vec3(jitter(rng), jitter(rng), jitter(rng)), glm::uintBitsToFloat(uint32_t(E.keys[s] & 0xffff)));
      }
      std::vector<ref::CpResult> want(lookups);
      auto tr = std::chrono::steady_clock::now();
      tbb::parallel_for(tbb::blocked_range<size_t>(0, lookups), [&](const tbb::blocked_range<size_t>& br) {
        for (size_t i = br.begin(); i < br.end(); ++i)
          want[i] = ref::cp_lookup(E, glm::vec3(queries[i]), glm::floatBitsToUint(queries[i].w));
      });
      const double ref_s = seconds(tr);
      double gpu_s = std::numeric_limits<double>::infinity();
      float worst = 0;
      size_t mismatched_validity = 0;
      try {  // an embedding larger than one storage-buffer binding cannot be uploaded (yet): report, keep the CPU rows
        fields::GpuEmbedding ge(ctx, E);
        gpu::Buffer<glm::vec4> qb(ctx, queries, "queries"), out(ctx, lookups, "results");
        gpu::Buffer<uint32_t> valid(ctx, lookups, "valid");
        for (int rep = 0; rep < 3; ++rep) {
          gpu::Sequence seq(ctx);
          lookup.record(seq, ge, qb, out, valid, lookups);
          const auto tg = std::chrono::steady_clock::now();
          seq.submit_and_wait();
          gpu_s = std::min(gpu_s, seconds(tg));
        }
        const auto got = out.download();
        const auto got_valid = valid.download();
        for (uint32_t i = 0; i < lookups; ++i) {
          mismatched_validity += bool(got_valid[i]) != want[i].valid;
          if (want[i].valid) worst = std::max(worst, glm::length(glm::vec3(got[i]) - glm::vec3(want[i].value)));
        }
      } catch (const gpu::Error& e) {
        std::fprintf(stderr, "%s: GPU lookup skipped: %s\n", spec.c_str(), e.what());
      }
      const auto& rep = r.report;
      std::printf("%-16s %9.2f %9.2f %9.2f %9.2f %10.1f %10.1f %9.0f %12.2f %12.2f %8.1e%s\n", spec.c_str(),
                  rep.indicator_seconds, rep.embedding_seconds, rep.sizing_seconds, total,
                  double(rep.indicator_bytes) / 1048576.0, double(rep.embedding_bytes) / 1048576.0, peak_rss_mib(),
                  lookups / gpu_s / 1e6, lookups / ref_s / 1e6, worst, mismatched_validity ? "  VALIDITY MISMATCH" : "");
      const nlohmann::json j = {{"benchmark", "fields"}, {"device", ctx.info().name}, {"volume", spec},
                                {"indicator_s", rep.indicator_seconds}, {"embedding_s", rep.embedding_seconds},
                                {"sizing_s", rep.sizing_seconds}, {"total_s", total},
                                {"indicator_bytes", rep.indicator_bytes}, {"embedding_bytes", rep.embedding_bytes},
                                {"blocks", E.block_count()}, {"peak_rss_mib", peak_rss_mib()},
                                {"interfaces", rep.interfaces}, {"triple_curves", rep.triple_curves},
                                {"quadruple_points", rep.quadruple_points}, {"lookups", lookups},
                                {"gpu_lookups_per_s", lookups / gpu_s}, {"ref_lookups_per_s", lookups / ref_s},
                                {"max_gpu_ref_difference", worst}, {"validity_mismatches", mismatched_validity}};
      std::cout << j.dump() << '\n';
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "cpmesh-bench-fields: error: " << e.what() << '\n';
    return 1;
  }
}
