// Benchmark of the GPU particle iteration (issue 6): random particles on a sphere and on the wedge ball (all its
// features) at hexagonal density for their sizing, a fixed number of iterations in exact and Barnes-Hut modes, per-kernel GPU time (timestamps), pairs
// evaluated per second and the final energy, side by side. Then the population (issue 7) on synthetic volumes:
// the paper's seeding against grid points alone, each relaxed with add/delete rounds to a settled population:
// seeds, final particles, rounds, iterations, time. With --scaling: Barnes-Hut iterations on the sphere as the
// particle count grows (issue 9): time per iteration and per stage of the iteration, device memory, log-log
// exponents fitted over the counts, and the memory of the fields per interface voxel. Prints tables and one JSON
// line per run.
//   cpmesh-bench-particles [--device D] [--particles 10000,100000] [--iterations 10] [--theta 0.75]
//                          [--population wedge-ball:48,sphere:64] [--scaling 10000,100000,1000000,2000000]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <random>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "bench_util.h"
#include "fields/fields_stage.h"
#include "fields/volume_grid.h"
#include "gpu/describe.h"
#include "io/synth_volumes.h"
#include "particles/particle_system.h"
#include "particles/population.h"
#include "ref/cp_lookup.h"

using namespace cpmesh;

namespace {

// The stages of one iteration, by kernel: sort (Morton codes and radix passes), tree (octree levels, scans,
// compaction, moments), walk (the octree walk of either mode, or the neighbour lists' builds and sums), advect (move
// and project), other (energy reduction, list drift).
const char* kernel_stage(const std::string& kernel) {
  if (kernel == "morton_codes" || kernel.rfind("radix", 0) == 0) return "sort";
  if (kernel.rfind("octree", 0) == 0 || kernel.rfind("scan", 0) == 0 || kernel.rfind("compact", 0) == 0) return "tree";
  if (kernel.rfind("tree_walk", 0) == 0 || kernel == "neighbour_energy") return "walk";
  if (kernel == "advect") return "advect";
  return "other";
}

template <class Start>
void run_scaling(gpu::Context& ctx, fields::FieldsResult& F, std::vector<uint32_t> counts, int iterations, float theta,
                 Start&& sphere_start) {
  std::sort(counts.begin(), counts.end());
  // The octree is rebuilt (sort and tree) once every rebuild_every steps and refitted in between, so a run of a
  // multiple of rebuild_every steps times the rebuild's share per iteration; fewer would time none of it.
  const int every = std::max(particles::AdvectionOptions{}.rebuild_every, 1);
  iterations = (std::max(iterations, 1) + every - 1) / every * every;
  const char* stages[] = {"sort", "tree", "walk", "advect", "other"};
  std::printf("\nScaling on %s: Barnes-Hut (theta %.2f) on the sphere, %d iterations per count (octree rebuilt every "
              "%d); ms per iteration, device memory of the particle system\n",
              ctx.info().name.c_str(), double(theta), iterations, every);
  std::printf("%10s %10s %9s %9s %9s %9s %9s %11s %12s\n", "particles", "ms/iter", "sort", "tree", "walk", "advect",
              "other", "device MiB", "ns/particle");
  std::vector<double> xs, total;
  std::map<std::string, std::vector<double>> per_stage;
  std::vector<double> device_bytes;
  nlohmann::json rows = nlohmann::json::array();
  for (uint32_t n : counts) {
    const auto start = sphere_start(n);
    ctx.release_pooled();  // the previous count's buffers would otherwise be recycled into this one's
    const uint64_t before = ctx.memory_stats().current_bytes;
    particles::AdvectionOptions opt;
    opt.theta = theta;
    particles::ParticleSystem system(ctx, F.embedding, start, std::vector<uint32_t>(n, 0), opt);
    system.step();  // warm-up
    const double bytes = double(ctx.memory_stats().current_bytes - before);
    ctx.clear_profile();
    const auto t0 = std::chrono::steady_clock::now();
    for (int it = 0; it < iterations; ++it) system.step();
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() / iterations;
    std::map<std::string, double> stage_ms;
    for (const char* st : stages) stage_ms[st] = 0;
    for (const auto& [kernel, entry] : ctx.profile()) stage_ms[kernel_stage(kernel)] += entry.total_ms / iterations;
    xs.push_back(double(n));
    total.push_back(ms);
    device_bytes.push_back(bytes);
    for (const char* st : stages) per_stage[st].push_back(stage_ms[st]);
    std::printf("%10u %10.1f %9.1f %9.1f %9.1f %9.1f %9.1f %11.1f %12.1f\n", n, ms, stage_ms["sort"], stage_ms["tree"],
                stage_ms["walk"], stage_ms["advect"], stage_ms["other"], bytes / 1048576.0, 1e6 * ms / double(n));
    rows.push_back({{"particles", n}, {"ms_per_iteration", ms}, {"stages_ms", stage_ms}, {"device_bytes", bytes}});
  }
  // Fitted exponents over all counts and over the upper half (where fixed per-dispatch costs no longer dominate).
  const size_t half = xs.size() / 2;
  auto upper = [&](const std::vector<double>& v) { return std::vector<double>(v.begin() + long(half), v.end()); };
  nlohmann::json exponents;
  // (Fewer than two counts in the upper half: "-", null in the JSON.)
  auto fit = [&](const char* name, const std::vector<double>& ys) {
    const double all = bench::loglog_slope(xs, ys), top = bench::loglog_slope(upper(xs), upper(ys));
    std::printf("fitted exponent k in time ~ n^k: %-8s all counts %s, upper half %s\n", name,
                bench::exponent_cell(all).c_str(), bench::exponent_cell(top).c_str());
    exponents[name] = {bench::exponent_json(all), bench::exponent_json(top)};
  };
  fit("total", total);
  for (const char* st : stages) fit(st, per_stage[st]);
  // Device memory = fixed (the embedding) + per particle: least-squares line through (n, bytes).
  double mx = 0, my = 0;
  for (size_t i = 0; i < xs.size(); ++i) mx += xs[i] / double(xs.size()), my += device_bytes[i] / double(xs.size());
  double sxy = 0, sxx = 0;
  for (size_t i = 0; i < xs.size(); ++i) sxy += (xs[i] - mx) * (device_bytes[i] - my), sxx += (xs[i] - mx) * (xs[i] - mx);
  const double per_particle = sxx > 0 ? sxy / sxx : 0.0, fixed = my - per_particle * mx;
  std::printf("device memory: %.0f bytes per particle + %.1f MiB fixed (the embedding and tables)\n", per_particle,
              fixed / 1048576.0);
  std::cout << nlohmann::json{{"benchmark", "scaling"}, {"device", ctx.info().name}, {"theta", theta},
                              {"iterations", iterations}, {"rows", rows}, {"exponents_all_upper", exponents},
                              {"device_bytes_per_particle", per_particle}, {"device_bytes_fixed", fixed}}
                   .dump()
            << '\n';
}

// Host memory of the fields per interface voxel (a voxel with a 6-neighbour of another label): what grows with the
// interface area rather than the volume.
void fields_memory_row(const std::string& spec) {
  const auto vol = bench::load_volume_spec(spec).volume;
  const auto grid = fields::grid_of(vol);
  const auto F = fields::build_fields(grid, vol.labels.data());
  const uint64_t interface_voxels = F.report.boundary_voxels;
  const double ind = double(F.report.indicator_bytes), emb = double(F.report.embedding_bytes);
  const double iv = double(std::max<uint64_t>(interface_voxels, 1));
  std::printf("%-16s %12llu %14.0f %14.0f %14.0f\n", spec.c_str(), static_cast<unsigned long long>(interface_voxels),
              ind / iv, emb / iv, (ind + emb) / iv);
  std::cout << nlohmann::json{{"benchmark", "fields_memory"}, {"volume", spec}, {"interface_voxels", interface_voxels},
                              {"indicator_bytes", ind}, {"embedding_bytes", emb},
                              {"bytes_per_interface_voxel", (ind + emb) / iv}}
                   .dump()
            << '\n';
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Benchmark of the GPU particle iteration (exact and Barnes-Hut walks)"};
  std::string device;
  std::vector<uint32_t> counts = {10000, 100000};
  int iterations = 10;
  float theta = 0.75f;
  app.add_option("--device", device, "Vulkan device index or name substring");
  app.add_option("--particles", counts, "Particle counts")->delimiter(',')->capture_default_str();
  app.add_option("--iterations", iterations, "Iterations timed per run")->capture_default_str();
  app.add_option("--theta", theta, "Barnes-Hut opening angle of the second mode")->capture_default_str();
  std::vector<std::string> populations = {"wedge-ball:48"};
  app.add_option("--population", populations,
                 "Volumes (shape:size) for the seeding comparison, shape = sphere, wedge-ball, slabs or shells")
      ->delimiter(',')
      ->capture_default_str();
  std::vector<uint32_t> scaling;
  app.add_option("--scaling", scaling,
                 "Particle counts of the scaling table (Barnes-Hut, sphere); given alone, only that table runs")
      ->delimiter(',');
  CLI11_PARSE(app, argc, argv);
  if (!scaling.empty() && app.count("--particles") == 0) counts.clear();
  if (!scaling.empty() && app.count("--population") == 0) populations.clear();
  try {
    gpu::Context ctx(gpu::ContextOptions{device, false, true});
    // One sphere (radius 40 voxels in 96^3); h is set per run so the sphere holds the asked number of particles.
    io::SynthOptions so;
    so.shape = io::SynthShape::sphere;
    so.size = 96;
    so.radius = 40;
    const auto vol = io::make_synth_volume(so);
    const glm::dvec3 centre(vol.centre[0], vol.centre[1], vol.centre[2]);
    auto F = fields::build_fields(fields::grid_of(vol.volume), vol.volume.labels.data());
    if (!counts.empty()) {
      std::printf("Particle iterations on %s, %d iterations per run; sphere: R = 40 voxels in 96^3, wedge ball: 128^3, "
                  "random particles at hexagonal density for h\n",
                  ctx.info().name.c_str(), iterations);
      std::printf("%-11s %-10s %-8s %10s %12s %14s %12s %12s %14s\n", "volume", "particles", "walk", "ms/iter",
                "walk ms/iter", "Mpairs/s", "pairs/part", "nodes/part", "final energy");
    }
    // Times `iterations` steps of both walks from one start and prints a row and a JSON line for each.
    auto time_modes = [&](const char* volume, const fields::ClosestPointEmbedding& E, const std::vector<glm::vec4>& start,
                          const std::vector<uint32_t>& features) {
      const uint32_t n = uint32_t(start.size());
      struct Mode {
        const char* name;
        float theta, skin;
      };
      const float skin = particles::AdvectionOptions{}.neighbour_skin;
      for (const Mode& m : {Mode{"exact", 0.0f, 0.0f}, Mode{"lists", 0.0f, skin}, Mode{"theta", theta, 0.0f}}) {
        particles::AdvectionOptions opt;
        opt.theta = m.theta;
        opt.neighbour_skin = m.skin;
        particles::ParticleSystem system(ctx, E, start, features, opt);
        system.step();  // warm-up (pipelines, first allocation touches)
        ctx.clear_profile();
        double energy = 0;
        uint64_t pairs = 0, visits = 0;
        const auto t0 = std::chrono::steady_clock::now();
        for (int it = 0; it < iterations; ++it) {
          energy = system.step().energy;
          pairs += system.last_pair_count();
          visits += system.last_node_visits();
        }
        const double wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        double walk_ms = 0;
        nlohmann::json kernels = gpu::profile_json(ctx);
        // The energy's kernels: the walk of either mode, or the list builds' walks and the sums over the lists.
        for (const auto& [kernel, entry] : ctx.profile())
          if (std::string(kernel_stage(kernel)) == "walk") walk_ms += entry.total_ms;
        const double per_iter = wall_ms / iterations;
        const double mpairs = double(pairs) / (walk_ms > 0 ? walk_ms : wall_ms) / 1e3;
        const double nodes_per_particle = double(visits) / double(iterations) / double(n);
        std::printf("%-11s %-10u %-8s %10.1f %12.1f %14.2f %12.1f %12.1f %14.6g\n", volume, n,
                    m.name, per_iter, walk_ms / iterations, mpairs,
                    double(pairs) / double(iterations) / double(n), nodes_per_particle, energy);
        const nlohmann::json j = {{"benchmark", "particles"}, {"device", ctx.info().name}, {"volume", volume},
                                  {"particles", n}, {"mode", m.name}, {"theta", m.theta},
                                  {"skin", m.skin}, {"list_builds", system.list_builds()},
                                  {"iterations", iterations}, {"ms_per_iteration", per_iter},
                                  {"walk_ms_per_iteration", walk_ms / iterations}, {"mpairs_per_s", mpairs},
                                  {"nodes_per_particle", nodes_per_particle}, {"final_energy", energy},
                                  {"kernels_ms", kernels}};
        std::cout << j.dump() << '\n';
      }
    };
    // n random particles on the sphere, the sizing field set to h for hexagonal density.
    auto sphere_start = [&](uint32_t n) {
      const float h = float(std::sqrt(4.0 * M_PI * 40.0 * 40.0 / (0.866 * n)));
      for (auto& p : F.embedding.fine) p.w = h;
      std::mt19937 rng(n);
      std::normal_distribution<double> n01;
      std::vector<glm::vec4> start;
      while (start.size() < n) {
        const glm::dvec3 dir = glm::normalize(glm::dvec3(n01(rng), n01(rng), n01(rng)));
        const auto cp = ref::cp_lookup(F.embedding, glm::vec3(centre + 40.0 * dir), 0);
        if (cp.valid) start.push_back(cp.value);
      }
      return start;
    };
    for (uint32_t n : counts) time_modes("sphere", F.embedding, sphere_start(n), std::vector<uint32_t>(n, 0));
    if (!scaling.empty()) {
      run_scaling(ctx, F, scaling, iterations, theta, sphere_start);
      std::printf("\nFields memory (host) per interface voxel\n%-16s %12s %14s %14s %14s\n", "volume", "iface voxels",
                  "indicator B", "embedding B", "total B");
      for (const char* spec : {"sphere:64", "wedge-ball:64", "wedge-ball:128", "shells:128"}) fields_memory_row(spec);
    }

    if (counts.empty()) return 0;
    // The wedge ball: particles on all 9 interfaces and 8 triple curves and at the 4 quadruple points, each a random
    // point of a random touching block of its feature projected by the lookup; h from the interface area (one
    // touching block per voxel of surface, about) so the count is at hexagonal density.
    io::SynthOptions wo;
    wo.shape = io::SynthShape::wedge_ball;
    wo.size = 128;
    const auto wv = io::make_synth_volume(wo);
    auto W = fields::build_fields(fields::grid_of(wv.volume), wv.volume.labels.data());
    auto& WE = W.embedding;
    std::vector<std::pair<uint32_t, uint32_t>> touching;  // (slot, feature)
    size_t interface_blocks = 0;
    for (size_t slot = 0; slot < WE.keys.size(); ++slot) {
      if (WE.keys[slot] == fields::ClosestPointEmbedding::kEmpty) continue;
      const uint32_t f = uint32_t(WE.keys[slot] & 0xffff);
      if (WE.features[f].kind == fields::FeatureKind::quadruple_point) continue;
      if (!WE.touches_feature(size_t(WE.keys[slot] >> 16), WE.blocks[slot])) continue;
      touching.push_back({uint32_t(slot), f});
      interface_blocks += WE.features[f].kind == fields::FeatureKind::interface;
    }
    for (uint32_t n : counts) {
      const float h = float(std::sqrt(double(interface_blocks) / (0.866 * n)));
      for (auto& p : WE.fine) p.w = h;
      std::mt19937 rng(n + 1);
      std::uniform_int_distribution<size_t> pick(0, touching.size() - 1);
      std::uniform_real_distribution<float> u(-0.5f, 0.5f);
      std::vector<glm::vec4> start;
      std::vector<uint32_t> features;
      for (const auto& q : WE.quadruple_points) {
        start.push_back(glm::vec4(glm::vec3(q.position), h));
        features.push_back(q.feature);
      }
      while (start.size() < n) {
        const auto [slot, f] = touching[pick(rng)];
        const glm::vec3 cell(WE.grid.local(glm::dvec3(WE.grid.voxel(size_t(WE.keys[slot] >> 16)))));
        const auto cp = ref::cp_lookup(WE, cell + glm::vec3(u(rng), u(rng), u(rng)), f);
        if (!cp.valid) continue;
        start.push_back(cp.value);
        features.push_back(f);
      }
      time_modes("wedge-ball", WE, start, features);
    }

    if (std::any_of(populations.begin(), populations.end(), [](const std::string& p) { return !p.empty(); })) {
      std::printf("\nPopulation on %s: seeding (Sec. 6.1) against grid points alone, add/delete rounds to the end\n",
                  ctx.info().name.c_str());
      std::printf("%-16s %-8s %9s %10s %7s %11s %10s %10s %9s\n", "volume", "seeding", "seeds", "particles", "rounds",
                  "iterations", "ms/iter", "seconds", "ended");
    }
    for (const std::string& spec : populations) {
      if (spec.empty()) continue;
      const auto colon = spec.find(':');
      io::SynthOptions po;
      po.shape = io::parse_synth_shape(spec.substr(0, colon));
      po.size = colon == std::string::npos ? 48 : std::stoi(spec.substr(colon + 1));
      const auto pv = io::make_synth_volume(po);
      const auto PF = fields::build_fields(fields::grid_of(pv.volume), pv.volume.labels.data());
      for (bool grid_only : {false, true}) {
        particles::PopulationOptions popt;
        particles::SeedStats st;
        const auto t0 = std::chrono::steady_clock::now();
        const auto seeds = particles::seed_population(PF.embedding, popt, &st, grid_only);
        const auto r = particles::relax(ctx, PF.embedding, seeds, {}, popt);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        double advect = 0;
        for (const auto& rr : r.rounds) advect += rr.advect_seconds;
        const double ms_per_iter = r.iterations ? 1e3 * advect / r.iterations : 0.0;
        const char* ended = r.settled ? "settled" : r.steady ? "steady" : "limit";
        std::printf("%-16s %-8s %9zu %10zu %7zu %11d %10.1f %10.2f %9s\n", spec.c_str(), grid_only ? "grid" : "paper",
                    st.kept, r.population.particles.size(), r.rounds.size(), r.iterations, ms_per_iter, seconds, ended);
        const nlohmann::json j = {{"benchmark", "population"}, {"device", ctx.info().name}, {"volume", spec},
                                  {"seeding", grid_only ? "grid" : "paper"}, {"seeds", st.kept},
                                  {"particles", r.population.particles.size()}, {"rounds", r.rounds.size()},
                                  {"iterations", r.iterations}, {"ms_per_iteration", ms_per_iter},
                                  {"seconds", seconds}, {"ended", ended}};
        std::cout << j.dump() << '\n';
      }
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "cpmesh-bench-particles: error: " << e.what() << '\n';
    return 1;
  }
}
