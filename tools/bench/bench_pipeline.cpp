// Benchmark of the whole pipeline (issue 9; mesh::mesh_volume): for each volume, time per stage (the load, the
// fields' and the Delaunay stage's steps apart), peak host and device memory, particles, iterations, add/delete rounds, triangles, tets and the quality measures; a table row and
// a JSON line per volume. Volumes are synthetic (shape:size) or files.
//   cpmesh-bench-pipeline [--device D] [--volumes wedge-ball:64,wedge-ball:128,wedge-ball:256,shells:128]
//                         [--only-surfaces] [--max-size H] [--min-size H] [--seed S] [--no-peer] [--peer-match]
//                         [--compare-delaunay] [--repeat N]
// Where cpmesh-peer-cgal was built (CGAL installed), each volume also gets a CGAL Mesh_3 row from the same binary
// directory, run in a child process at --peer-facet-size (voxels): time, triangles, tets, radius ratio, dihedral;
// with --peer-match more CGAL rows, at facet sizes closing in on cpmesh's triangle count.
// Junction error (wedge ball): distance of the triple-curve edges' midpoints to the analytic curves, mean and max in
// voxels, for both. The scaling table is cpmesh-bench-particles --scaling. With --compare-delaunay the particles
// of each run are tetrahedralized again by TetGen (one thread) and by mesh::parallel_delaunay, same run. With
// --repeat N each volume runs N times, each run followed by its peer run, and a summary line gives the medians, the
// median ratio of the pairs and how often cpmesh was the faster.

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <cstdio>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <tbb/task_arena.h>

#include "bench_util.h"
#include "mesh/delaunay.h"
#include "mesh/pipeline.h"
#include "mesh/report_json.h"

using namespace cpmesh;
using bench::peak_rss_mib;

namespace {

// "mean/max/whole-edge max" in voxels, or "-" where the volume has no analytic junctions.
double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n == 0 ? 0.0 : n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// --repeat's summary of one volume: cpmesh's median total (and range), and where the peer ran after a run, the
// peer's median, the median of the runs' ratios (cpmesh / peer, each pair one after the other on the same machine)
// and how many runs cpmesh was the faster. A line and a "pipeline_repeat" JSON line.
void print_repeat_summary(const std::string& name, const std::string& device, const std::vector<double>& cpmesh,
                          const std::vector<std::pair<double, double>>& with_peer) {
  if (cpmesh.empty()) return;
  const auto [lo, hi] = std::minmax_element(cpmesh.begin(), cpmesh.end());
  nlohmann::json j = {{"benchmark", "pipeline_repeat"}, {"volume", name},     {"device", device},
                      {"runs", cpmesh.size()},          {"total_s", cpmesh}, {"median_s", median(cpmesh)}};
  std::printf("  %s: %zu runs, median %.2f s (%.2f-%.2f)", name.c_str(), cpmesh.size(), median(cpmesh), *lo, *hi);
  if (!with_peer.empty()) {
    std::vector<double> peer, ratio;
    size_t faster = 0;
    for (const auto& [c, p] : with_peer) {
      peer.push_back(p);
      ratio.push_back(c / p);
      faster += c < p;
    }
    const auto [plo, phi] = std::minmax_element(peer.begin(), peer.end());
    std::printf("; CGAL median %.2f s (%.2f-%.2f); cpmesh / CGAL median %.3f, faster in %zu of %zu", median(peer),
                *plo, *phi, median(ratio), faster, with_peer.size());
    j["peer_total_s"] = peer;
    j["peer_median_s"] = median(peer);
    j["median_ratio"] = median(ratio);
    j["faster_runs"] = faster;
    j["runs_with_peer"] = with_peer.size();
  }
  std::printf("\n%s\n", j.dump().c_str());
  std::fflush(stdout);
}

std::string junction_cell(bool known, const mesh::JunctionError& e) {
  if (!known) return "-";
  char cell[64];
  std::snprintf(cell, sizeof cell, "%.2f/%.2f/%.2f", e.mean, e.max, e.max_whole_edge);
  return cell;
}

}  // namespace


int main(int argc, char** argv) {
  CLI::App app{"Benchmark of the whole pipeline: labels to interface and tet meshes"};
  std::string device;
  std::vector<std::string> volumes = {"wedge-ball:64", "wedge-ball:128", "wedge-ball:256", "shells:128"};
  bool only_surfaces = false;
  double max_size = 0, min_size = 0;
  app.add_option("--device", device, "Vulkan device index or name substring");
  app.add_option("--volumes", volumes, "shape:size (sphere, wedge-ball, slabs, shells, head) or volume files")
      ->delimiter(',')
      ->capture_default_str();
  app.add_flag("--only-surfaces", only_surfaces, "Skip the volume mesh");
  app.add_option("--max-size", max_size, "Largest h, physical units (0: 4 voxels)")->capture_default_str();
  app.add_option("--min-size", min_size,
                 "Smallest h, physical units (0: a quarter voxel; thin layers ask for it, so it sets their cost)")
      ->capture_default_str();
  int subcells = mesh::MeshOptions{}.fields.embedding.sub;
  double band = mesh::MeshOptions{}.fields.indicator.band;
  app.add_option("--subcells", subcells,
                 "Closest point embedding: fine points per voxel and axis (0: 1 when --min-size is at least a voxel "
                 "and thin parts are at most 2% of the label boundary, else 2)")
      ->check(CLI::Range(0, 4))
      ->capture_default_str();
  app.add_option("--band", band,
                 "Narrow band of the indicator fields, voxels (0: 4, or deeper where the embedding needs it)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  float skin = mesh::MeshOptions{}.advection.neighbour_skin;
  app.add_option("--skin", skin, "Verlet neighbour lists' skin, a share of h (0: walk the octree every iteration)")
      ->check(CLI::Range(0.0, 4.0))
      ->capture_default_str();
  size_t max_particles = mesh::MeshOptions{}.max_particles;
  app.add_option("--max-particles", max_particles,
                 "A volume whose seeding makes more particles stops there and gets a row saying so (0: no limit); "
                 "caps thin-layered volumes on slow devices")
      ->capture_default_str();
  uint32_t seed = mesh::MeshOptions{}.population.seed;
  app.add_option("--seed", seed, "Random seed of the particle population (same seed, same result)")
      ->capture_default_str();
  size_t volume_runs = mesh::MeshOptions{}.volume.runs;
  app.add_option("--volume-runs", volume_runs,
                 "Volume mesh: TetGen runs to aim at, large materials cut into pieces (0: one per thread; 1: one per "
                 "material; cpmesh mesh --volume-runs)")
      ->capture_default_str();
  bool interior_points = mesh::MeshOptions{}.volume.interior_points;
  app.add_flag("!--no-interior-points", interior_points,
               "Volume mesh: TetGen refines from the surface vertices alone (cpmesh mesh --no-interior-points)");
  int repeat = 1;
  app.add_option("--repeat", repeat,
                 "Run each volume this many times, each run followed by its CGAL peer run, then print the medians, "
                 "the median of the runs' time ratios and how often cpmesh was faster (a noisy machine's comparison)")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  double peer_facet = 1.5;
  bool no_peer = false, peer_match = false;
  app.add_option("--peer-facet-size", peer_facet, "CGAL peer: facet size in voxels")->capture_default_str();
  app.add_flag("--no-peer", no_peer, "Skip the CGAL peer even where it was built");
  app.add_flag("--peer-match", peer_match,
               "Run the CGAL peer again at the facet size that gives about cpmesh's triangle count (rows marked "
               "'='; up to three runs, until within 15%)");
  bool compare_delaunay = false;
  app.add_flag("--compare-delaunay", compare_delaunay,
               "After each run, tetrahedralize its particles again with TetGen (one thread) and with the "
               "pipeline's parallel Delaunay (every thread), same points, same run: a line and \"delaunay_compare\" "
               "in the JSON");
  std::vector<double> sweep;
  app.add_option("--sweep-max-size", sweep,
                 "Scaling: run each volume at each of these largest h (physical units, e.g. 4,2,1,0.5) instead of "
                 "--max-size, then print how each stage's time grows with the particle count (log-log fitted "
                 "exponents); no CGAL peer")
      ->delimiter(',')
      ->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);
  try {
    for (const std::string& spec : volumes) bench::check_volume_spec(spec);  // a typo fails now, not after hours
    gpu::Context ctx(gpu::ContextOptions{device, false, false});
    // The table's time columns: the load, then each stage, where a stage has steps (MeshReport::steps) its steps in
    // its place. The JSON line has both the stages ("seconds") and the steps ("steps").
    struct Column {
      const char* stage;
      const char* step;  // nullptr: the whole stage
      const char* head;
    };
    const Column columns[] = {{"fields", "indicator fields", "indicator"},
                              {"fields", "embedding", "embedding"},
                              {"fields", "sizing field", "sizing"},
                              {"seeding", nullptr, "seeding"},
                              {"advection", nullptr, "advection"},
                              {"delaunay and extraction", "tetrahedralization", "delaunay"},
                              {"delaunay and extraction", "extraction", "extract"},
                              {"smoothing", nullptr, "smoothing"},
                              {"quality", nullptr, "quality"},
                              {"volume mesh", nullptr, "volume"}};
    std::printf("Pipeline on %s (seconds per stage; it/rnd: advection iterations/rounds)\n%-16s %6s", ctx.info().name.c_str(),
                "volume", "load");
    for (const Column& c : columns) std::printf(" %9s", c.head);
    std::printf(" %7s %8s %9s %9s %9s %7s %7s %8s %14s %8s %8s\n", "it/rnd", "total s", "particles", "triangles",
                "tets", "rr mean", "rr min", "dihedral", "junction", "host MiB", "dev MiB");
    for (const std::string& spec : volumes) {
      // Load: reading the file, or making the synthetic volume.
      const auto load_start = std::chrono::steady_clock::now();
      const auto [volume, junctions] = bench::load_volume_spec(spec);
      const double load_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - load_start).count();
      std::vector<bench::ScalingRow> scaling;  // with --sweep-max-size: one per run that finished
      for (const double h_max : sweep.empty() ? std::vector<double>{max_size} : sweep) {
        const std::string name = sweep.empty() ? spec : spec + " h" + bench::short_number(h_max);
        std::vector<double> cpmesh_times;                  // every run's total (--repeat's summary)
        std::vector<std::pair<double, double>> with_peer;  // cpmesh's and the peer's, runs whose peer ran
        for (int run = 0; run < repeat; ++run) {
          mesh::MeshOptions options;
          options.only_surfaces = only_surfaces;
          options.fields.sizing.h_max = h_max;
          options.fields.sizing.h_min = min_size;
          options.fields.embedding.sub = subcells;
          options.fields.indicator.band = band;
          options.advection.neighbour_skin = skin;
          options.max_particles = max_particles;
          options.population.seed = seed;
          options.volume.runs = volume_runs;
          options.volume.interior_points = interior_points;
          const auto t0 = std::chrono::steady_clock::now();
          mesh::MeshResult r;
          try {
            // Each finished stage, and the progress within one, on stderr (the table and JSON stay on stdout): a long run shows where it is.
            r = mesh::mesh_volume(ctx, volume, options, [&](const mesh::StageEvent& e) {
              if (e.seconds < 0) {
                if (!e.detail.empty()) std::fprintf(stderr, "  %s: %s: %s\n", name.c_str(), e.stage.c_str(), e.detail.c_str());
              } else {
                std::fprintf(stderr, "  %s: %s %.2f s, %s\n", name.c_str(), e.stage.c_str(), e.seconds, e.detail.c_str());
              }
              std::fflush(stderr);
            });
          } catch (const mesh::ParticleBudgetError& e) {
            std::printf("%-16s stopped: %s\n", name.c_str(), e.what());
            std::printf("%s\n", nlohmann::json{{"benchmark", "pipeline"}, {"volume", spec}, {"device", ctx.info().name},
                                               {"stopped", e.what()}}.dump().c_str());
            std::fflush(stdout);
            break;  // every repeat would stop alike
          }
          const double total = load_seconds + std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          cpmesh_times.push_back(total);
          const auto& rep = r.report;
          std::printf("%-16s %6.2f", name.c_str(), load_seconds);
          nlohmann::json seconds = {{"load", load_seconds}}, steps = nlohmann::json::object();
          for (const auto& [stage, sec] : rep.seconds) seconds[stage] = sec;
          for (const auto& step : rep.steps) steps[step.stage][step.step] = step.seconds;
          for (const Column& c : columns) {
            const nlohmann::json* in = !c.step ? &seconds : steps.contains(c.stage) ? &steps.at(c.stage) : nullptr;
            const char* key = c.step ? c.step : c.stage;
            if (in && in->contains(key)) std::printf(" %9.2f", in->at(key).get<double>());
            else std::printf(" %9s", "-");  // a stage the run did not reach or skipped (the volume mesh)
          }
          const std::string it_rounds = std::to_string(rep.iterations) + "/" + std::to_string(rep.rounds);
          std::printf(" %7s", it_rounds.c_str());
          const double dev_mib = double(ctx.memory_stats().peak_bytes) / 1048576.0;
          mesh::JunctionError je;
          if (junctions)
            je = mesh::junction_error(*junctions, r.surfaces.vertices, r.surfaces.triangles, r.surfaces.triangle_pair,
                                      std::min({volume.spacing[0], volume.spacing[1], volume.spacing[2]}));
          std::printf(" %8.2f %9zu %9zu %9zu %7.3f %7.3f %8.1f %14s %8.0f %8.0f\n", total, rep.particles,
                      rep.surface.triangles, rep.volume.tets, rep.surface.mean_radius_ratio, rep.surface.min_radius_ratio,
                      rep.volume.min_dihedral_deg, junction_cell(junctions.has_value(), je).c_str(), peak_rss_mib(), dev_mib);
          nlohmann::json j = {
              {"benchmark", "pipeline"}, {"device", ctx.info().name}, {"volume", spec}, {"seconds", seconds},
              {"steps", steps},
              {"total_s", total}, {"particles", rep.particles}, {"iterations", rep.iterations}, {"rounds", rep.rounds},
              {"triangles", rep.surface.triangles}, {"tets", rep.volume.tets},
              {"mean_radius_ratio", rep.surface.mean_radius_ratio}, {"min_radius_ratio", rep.surface.min_radius_ratio},
              {"share_below_0_5", rep.surface.share_below_half}, {"min_dihedral_deg", rep.volume.min_dihedral_deg},
              {"interfaces_manifold", rep.interfaces_manifold}, {"interfaces", rep.interfaces.size()},
              {"materials_closed", rep.materials_closed}, {"wrong_faces", rep.wrong_faces},
              {"wrong_faces_before_repair", rep.wrong_faces_before_repair},
              {"crossing_triangles", rep.crossing_triangles},
              {"off_feature_particles", rep.off_feature_particles}, {"crowded_particles", rep.crowded_particles},
              {"protected_particles", rep.protected_particles},
              {"peak_host_mib", peak_rss_mib()}, {"peak_device_mib", dev_mib},
              {"settings",
               {{"min_size", min_size}, {"max_size", h_max}, {"only_surfaces", only_surfaces}, {"subcells", rep.subcells},
                {"band", rep.band_voxels}, {"skin", skin},
                {"max_particles", max_particles}, {"seed", seed}, {"interior_points", interior_points}}}};
          if (junctions) j["junction_error"] = bench::junction_json(je);
          if (!rep.volume_runs.empty())  // where the volume mesh's time went: the runs go in parallel
            j["volume_runs"] = mesh::volume_runs_json(rep);
          if (!rep.volume_unsplit_because.empty()) j["volume_unsplit_because"] = rep.volume_unsplit_because;
          if (!only_surfaces)
            j["slivers"] = {{"min_dihedral_deg_from_tetgen", rep.tet_improvement.min_dihedral_before},
                            {"moves", rep.tet_improvement.moves}, {"flips", rep.sliver_split.flips},
                            {"splits", rep.sliver_split.inserted}, {"cavities_remeshed", rep.sliver_split.remeshed},
                            {"left", rep.sliver_split.failed},
                            {"separator_points", rep.volume_separator_points}};
          if (compare_delaunay) {
            std::vector<glm::dvec3> P;
            for (const auto& v : r.particles.vertices) P.push_back({v[0], v[1], v[2]});
            const auto t0 = std::chrono::steady_clock::now();
            const size_t tetgen_tets = mesh::delaunay(P).tets.size();
            const auto t1 = std::chrono::steady_clock::now();
            mesh::DelaunayStats st;
            const size_t parallel_tets = mesh::parallel_delaunay(P, &st).tets.size();
            const auto t2 = std::chrono::steady_clock::now();
            const double tetgen_s = std::chrono::duration<double>(t1 - t0).count();
            const double parallel_s = std::chrono::duration<double>(t2 - t1).count();
            const int threads = tbb::this_task_arena::max_concurrency();
            std::printf("  Delaunay of its %zu particles: TetGen (one thread) %.2f s, %zu tets; parallel (%d threads) "
                        "%.2f s, %zu tets%s\n", P.size(), tetgen_s, tetgen_tets, threads, parallel_s, parallel_tets,
                        st.fell_back ? (", fell back: " + st.why).c_str() : "");
            j["delaunay_compare"] = {{"points", P.size()},         {"threads", threads},
                                     {"tetgen_s", tetgen_s},       {"tetgen_tets", tetgen_tets},
                                     {"parallel_s", parallel_s},   {"parallel_tets", parallel_tets},
                                     {"rounds", st.rounds},        {"retries", st.retries},
                                     {"fell_back", st.fell_back}};
          }
          std::cout << j.dump() << '\n';
          if (!sweep.empty()) {
            bench::ScalingRow row{h_max, double(rep.particles), {{"total", total}}};
            for (const auto& [stage, sec] : seconds.items()) row.seconds[stage] = sec.get<double>();
            for (const auto& [stage, parts] : steps.items())
              for (const auto& [step, sec] : parts.items()) row.seconds[step] = sec.get<double>();
            if (rep.iterations > 0) row.seconds["advection iteration"] = seconds["advection"].get<double>() / rep.iterations;
            scaling.push_back(row);
          }

          // The peer, in a child process (its own memory, its own failures).
          const auto peer = std::filesystem::read_symlink("/proc/self/exe").parent_path() / "cpmesh-peer-cgal";
          if (no_peer || !sweep.empty() || !std::filesystem::exists(peer)) continue;
          // One peer run at a facet size; returns its surface triangles (0 when it failed), its time in *seconds.
          auto run_peer = [&](double facet, const char* note, double* seconds = nullptr) -> int {
            // The facet distance and cell size bounds scale with the facet size (0.5 and 3 voxels at the default 1.5),
            // or they alone set the count.
            const std::string command = peer.string() + " '" + spec + "' --facet-size " + std::to_string(facet) +
                                        " --facet-distance " + std::to_string(facet / 3) + " --cell-size " +
                                        std::to_string(2 * facet);
            std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(command.c_str(), "r"), pclose);
            std::string line;
            char buffer[4096];
            while (pipe && std::fgets(buffer, sizeof buffer, pipe.get())) line += buffer;
            try {
              auto pj = nlohmann::json::parse(line);
              std::printf("%-16s", ("  CGAL " + std::to_string(facet).substr(0, 4) + note).c_str());
              std::printf(" %6s", "");
              for (size_t k = 0; k < std::size(columns); ++k) std::printf(" %9s", "");
              std::printf(" %7s", "");
              mesh::JunctionError pje;
              if (pj.contains("junction_error")) {
                pje.edges = pj["junction_error"]["edges"].get<size_t>();
                pje.spurious = pj["junction_error"]["spurious"].get<size_t>();
                pje.mean = pj["junction_error"]["mean"].get<double>();
                pje.max = pj["junction_error"]["max"].get<double>();
                pje.max_whole_edge = pj["junction_error"].value("max_whole_edge", 0.0);
              }
              std::printf(" %8.2f %9s %9d %9d %7.3f %7.3f %8.1f %14s\n", pj["total_s"].get<double>(), "-",
                          pj["triangles"].get<int>(), pj["tets"].get<int>(), pj["mean_radius_ratio"].get<double>(),
                          pj["min_radius_ratio"].get<double>(), pj["min_dihedral_deg"].get<double>(),
                          junction_cell(pj.contains("junction_error"), pje).c_str());
              pj["matched_to_cpmesh"] = *note != 0;
              std::cout << pj.dump() << '\n';
              if (seconds) *seconds = pj["total_s"].get<double>();
              return pj["triangles"].get<int>();
            } catch (const std::exception& e) {
              std::printf("  CGAL peer failed on %s: %s\n", spec.c_str(), line.empty() ? "no output" : line.c_str());
              return 0;
            }
          };
          double peer_seconds = -1;
          int peer_triangles = run_peer(peer_facet, "", &peer_seconds);
          if (peer_triangles > 0) with_peer.push_back({total, peer_seconds});
          // Triangle count goes about as 1 / facet^2 (less where CGAL's distance bound adds triangles): up to three more
          // runs, each at the facet size that this predicts for cpmesh's count, until within 15% of it.
          double facet = peer_facet;
          for (int tries = 0; peer_match && tries < 3 && peer_triangles > 0 && rep.surface.triangles > 0; ++tries) {
            const double ratio = double(peer_triangles) / double(rep.surface.triangles);
            if (tries > 0 && std::fabs(ratio - 1) < 0.15) break;
            facet *= std::sqrt(ratio);
            peer_triangles = run_peer(facet, "=");
          }
        }
        if (repeat > 1) print_repeat_summary(name, ctx.info().name, cpmesh_times, with_peer);
      }
      if (!sweep.empty())
        bench::print_scaling(spec, scaling,
                             {"load", "indicator fields", "embedding", "sizing field", "seeding", "advection",
                              "advection iteration", "tetrahedralization", "extraction", "smoothing", "quality",
                              "volume mesh", "total"});
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "cpmesh-bench-pipeline: error: " << e.what() << '\n';
    return 1;
  }
}
