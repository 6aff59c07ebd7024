// `cpmesh particles`: fields, seeding, then advection with add/delete rounds (seed paper Sec. 5-6); writes the
// settled particles and a per-round report.
#include <cstdio>
#include <filesystem>
#include <memory>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "fields/device_fields.h"
#include "fields/fields_stage.h"
#include "fields/volume_grid.h"
#include "gpu/describe.h"
#include "io/atomic_file.h"
#include "io/mesh_writers.h"
#include "particles/population.h"
#include "progress.h"
#include "volume_input.h"

namespace cpmesh::cli {

void add_population_options(CLI::App* sub, particles::PopulationOptions& p) {
  sub->add_option("--seed-constant", p.random_seed_constant, "C: random seeds per grid point where h < 1 voxel, x 1/h (paper: 2)")->capture_default_str();
  sub->add_option("--seed-below", p.random_seed_below, "Sizing (voxels) below which random seeds are added (paper: 1)")->capture_default_str();
  sub->add_option("--seed-energy", p.seed_energy_factor, "A seed is kept if its energy is below this x ideal")->capture_default_str();
  sub->add_option("--delete-factor", p.delete_factor, "Delete candidate: energy above this x ideal")->capture_default_str();
  sub->add_option("--add-factor", p.add_factor, "Add candidate: energy below this x ideal")->capture_default_str();
  sub->add_option("--readd-factor", p.readd_factor, "A delete candidate is re-inserted if its energy is below this x ideal (paper: 4)")->capture_default_str();
  sub->add_option("--accept-factor", p.accept_factor, "A particle filling a hole is kept if its energy is below this x ideal")->capture_default_str();
  sub->add_option("--relaxed-energy", p.relaxed_energy_ratio, "Mean energy / ideal of a relaxed population at the ideal density")->capture_default_str();
  sub->add_option("--energy-tolerance", p.energy_tolerance, "Settled when each feature's mean energy is within this of the target")->capture_default_str();
  sub->add_option("--significance", p.significance, "... and at most this share of particles is flagged")->capture_default_str();
  sub->add_option("--steady-share", p.steady_share, "Steady when |added - deleted| is below this share two rounds running")->capture_default_str();
  sub->add_option("--steady-window", p.steady_window,
                  "... or |sum of (added - deleted)| over this many rounds below this many times that share (a "
                  "churn that swings the count up and down; 0: off)")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  sub->add_option("--negligible-share", p.negligible_share,
                  "... or at once when added + deleted is at most this share (the next run is the last)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  sub->add_option("--count-gain", p.count_gain, "Share of a feature's count error corrected per round")->capture_default_str();
  sub->add_option("--max-rounds", p.max_rounds, "Add/delete rounds at most")->capture_default_str();
  sub->add_option("--round-iterations", p.iterations_per_round, "Advection iterations per round at most")->capture_default_str();
  sub->add_option("--min-round-iterations", p.min_iterations_per_round, "Advection iterations per round at least")->capture_default_str();
  sub->add_option("--min-small-round-iterations", p.min_iterations_after_small_change,
                  "Advection iterations at least after an add/delete step that changed at most --small-change of the particles")
      ->capture_default_str();
  sub->add_option("--small-change", p.small_change_share, "Share of the particles an add/delete step changes at most to count as small")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  sub->add_option("--min-feature-particles", p.min_feature_particles, "Features with fewer particles get no count correction")->capture_default_str();
  sub->add_option("--add-tries", p.add_tries, "Random directions tried per add candidate")->capture_default_str();
  sub->add_option("--seed", p.seed, "Random seed (same seed, same result)")->capture_default_str();
  for (const char* name : {"--seed-constant", "--seed-below", "--seed-energy", "--delete-factor", "--add-factor",
                           "--readd-factor", "--accept-factor", "--relaxed-energy", "--energy-tolerance",
                           "--significance", "--steady-share", "--count-gain"})
    sub->get_option(name)->check(CLI::NonNegativeNumber);
  for (const char* name : {"--max-rounds", "--round-iterations", "--add-tries"}) sub->get_option(name)->check(CLI::PositiveNumber);
}

Command add_particles_command(CLI::App& app, const GlobalOptions& g) {
  struct Options {
    VolumeInput input;
    std::string out;
    fields::FieldsOptions fields;
    particles::AdvectionOptions advection;
    particles::PopulationOptions population;
    bool grid_seeding = false;
  };
  auto o = std::make_shared<Options>();
  auto* sub = app.add_subcommand(
      "particles", "Sample every interface, triple curve and quadruple point of a volume with particles: fields, "
                   "seeding, GPU advection with add/delete rounds; writes particles.vtp and particles.json");
  add_volume_input(sub, o->input);
  sub->add_option("-o,--out", o->out, "Output directory (created)")->required();
  add_fields_options(sub, o->fields);
  add_advection_options(sub, o->advection);
  add_population_options(sub, o->population);
  sub->add_flag("--grid-seeding", o->grid_seeding, "Seed with grid points only (BioMesh3D's seeding, for comparison)");
  return {sub, [o, &g] {
            Progress progress(5);
            io::LabelVolume input = progress.stage("read volume", [&] { return read_volume_input(o->input); });
            gpu::Context ctx(g.context());
            const auto device_fields = progress.stage("fields", [&] { return fields::build_device_fields(ctx, input, o->fields); });
            const io::LabelVolume& volume = device_fields.volume;
            const fields::Grid grid = fields::grid_of(volume);
            const auto& F = device_fields.fields;
            particles::SeedStats seeded;
            const auto seeds = progress.stage("seeding", [&] {
              return particles::seed_population(F.embedding, o->population, &seeded, o->grid_seeding);
            });
            const auto r = progress.stage("advection and add/delete", [&] {
              return particles::relax(ctx, F.embedding, seeds,
                                      particles::with_sizing_grading(o->advection, o->fields.sizing.grading),
                                      o->population,
                                      [](const particles::RoundReport& rr) {
                                        if (isatty(STDERR_FILENO))
                                          std::fprintf(stderr, "\n  round %d: %d iterations, +%u -%u, %u particles",
                                                       rr.round, rr.iterations, rr.added, rr.deleted, rr.total);
                                      });
            });
            std::filesystem::create_directories(o->out);
            const std::string dir = o->out + "/";
            progress.stage("write", [&] {
              io::TriangleMesh cloud;
              std::vector<float> feature_id, h;
              for (size_t i = 0; i < r.population.particles.size(); ++i) {
                const glm::vec4 q = r.population.particles[i];
                const glm::dvec3 phys = grid.to_physical(glm::dvec3(glm::vec3(q)));
                cloud.vertices.push_back({phys.x, phys.y, phys.z});
                const uint32_t fid = r.population.features[i];
                cloud.vertex_feature.push_back(uint8_t(F.embedding.features[fid].kind));
                feature_id.push_back(float(fid));
                h.push_back(q.w);
              }
              cloud.vertex_scalars = {{"feature_id", feature_id}, {"sizing", h}};
              io::write_vtp(dir + "particles.vtp", cloud);
              nlohmann::json j;
              j["volume"] = volume.source;
              j["device"] = ctx.info().name;
              j["seeding"] = {{"candidates", seeded.candidates}, {"random_candidates", seeded.random_candidates},
                              {"kept", seeded.kept}, {"grid_only", o->grid_seeding}};
              j["particles"] = r.population.particles.size();
              j["iterations"] = r.iterations;
              j["settled"] = r.settled;
              j["steady"] = r.steady;
              j["rounds"] = nlohmann::json::array();
              for (const auto& rr : r.rounds)
                j["rounds"].push_back({{"round", rr.round}, {"iterations", rr.iterations}, {"energy", rr.energy},
                                       {"flagged_delete", rr.flagged_delete}, {"flagged_add", rr.flagged_add},
                                       {"added", rr.added}, {"deleted", rr.deleted}, {"total", rr.total},
                                       {"max_feature_deviation", rr.max_feature_deviation},
                                       {"advect_s", rr.advect_seconds}, {"check_s", rr.check_seconds},
                                       {"host_s", rr.host_seconds}});
              io::write_atomically(dir + "particles.json", [&](std::ostream& out) { out << j.dump(2) << '\n'; });
            });
            std::printf("%s: %zu seeds (%zu candidates) -> %zu particles, %d iterations, %zu rounds (%s)\n",
                        volume.source.c_str(), seeded.kept, seeded.candidates, r.population.particles.size(),
                        r.iterations, r.rounds.size(), r.settled ? "settled" : r.steady ? "steady" : "round limit");
            std::printf("  %-6s %10s %8s %8s %9s %12s %9s %9s %9s\n", "round", "iterations", "added", "deleted",
                        "total", "energy", "advect s", "check s", "host s");
            for (const auto& rr : r.rounds)
              std::printf("  %-6d %10d %8u %8u %9u %12.4g %9.2f %9.3f %9.3f\n", rr.round, rr.iterations, rr.added,
                          rr.deleted, rr.total, rr.energy, rr.advect_seconds, rr.check_seconds, rr.host_seconds);
            std::printf("  %-26s %9s\n", "stage", "seconds");
            for (const auto& [name, s] : progress.times()) std::printf("  %-26s %9.2f\n", name.c_str(), s);
            std::printf("  wrote %s\n", o->out.c_str());
            print_profile(ctx, g);
            return 0;
          }};
}

}  // namespace cpmesh::cli
