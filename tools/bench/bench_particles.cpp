// Benchmark of the GPU particle iteration (issue 6): random particles on a sphere at hexagonal density for their
// sizing, a fixed number of iterations in exact and Barnes-Hut modes, per-kernel GPU time (timestamps), pairs
// evaluated per second and the final energy, side by side. Then the population (issue 7) on synthetic volumes:
// the paper's seeding against grid points alone, each relaxed with add/delete rounds to a settled population:
// seeds, final particles, rounds, iterations, time. Prints tables and one JSON line per run.
//   cpmesh-bench-particles [--device D] [--particles 10000,100000] [--iterations 10] [--theta 0.75]
//                          [--population wedge-ball:48,sphere:64]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <random>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "fields/fields_stage.h"
#include "fields/volume_grid.h"
#include "gpu/describe.h"
#include "io/synth_volumes.h"
#include "particles/particle_system.h"
#include "particles/population.h"
#include "ref/cp_lookup.h"

using namespace cpmesh;

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
  CLI11_PARSE(app, argc, argv);
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
    std::printf("Particle iterations on %s, sphere R = 40 voxels, %d iterations per run\n", ctx.info().name.c_str(),
                iterations);
    std::printf("%-10s %-8s %10s %12s %14s %12s %12s %14s\n", "particles", "walk", "ms/iter", "walk ms/iter",
                "Mpairs/s", "pairs/part", "nodes/part", "final energy");
    for (uint32_t n : counts) {
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
      for (float mode : {0.0f, theta}) {
        particles::AdvectionOptions opt;
        opt.theta = mode;
        particles::ParticleSystem system(ctx, F.embedding, start, std::vector<uint32_t>(n, 0), opt);
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
        if (ctx.profile().count("tree_walk")) walk_ms = ctx.profile().at("tree_walk").total_ms;
        const double per_iter = wall_ms / iterations;
        const double mpairs = double(pairs) / (walk_ms > 0 ? walk_ms : wall_ms) / 1e3;
        const double nodes_per_particle = double(visits) / double(iterations) / double(n);
        std::printf("%-10u %-8s %10.1f %12.1f %14.2f %12.1f %12.1f %14.6g\n", n, mode > 0 ? "theta" : "exact", per_iter,
                    walk_ms / iterations, mpairs, double(pairs) / double(iterations) / double(n), nodes_per_particle,
                    energy);
        const nlohmann::json j = {{"benchmark", "particles"}, {"device", ctx.info().name}, {"particles", n},
                                  {"mode", mode > 0 ? "theta" : "exact"}, {"theta", mode}, {"iterations", iterations},
                                  {"ms_per_iteration", per_iter}, {"walk_ms_per_iteration", walk_ms / iterations},
                                  {"mpairs_per_s", mpairs}, {"nodes_per_particle", nodes_per_particle},
                                  {"final_energy", energy}, {"kernels_ms", kernels}};
        std::cout << j.dump() << '\n';
      }
    }

    if (!populations.empty()) {
      std::printf("\nPopulation on %s: seeding (Sec. 6.1) against grid points alone, add/delete rounds to the end\n",
                  ctx.info().name.c_str());
      std::printf("%-16s %-8s %9s %10s %7s %11s %10s %10s %9s\n", "volume", "seeding", "seeds", "particles", "rounds",
                  "iterations", "ms/iter", "seconds", "ended");
    }
    for (const std::string& spec : populations) {
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
