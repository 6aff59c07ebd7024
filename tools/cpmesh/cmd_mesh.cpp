// `cpmesh mesh`: the whole pipeline (engine/mesh/pipeline.h): labels in; interface meshes, a tet mesh of every
// material, the particles and report.json out; a progress line per stage and a summary table.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <set>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "io/atomic_file.h"
#include "io/mesh_writers.h"
#include "io/png.h"
#include "mesh/pipeline.h"
#include "mesh/report_json.h"
#include "render/preview.h"
#include "progress.h"
#include "volume_input.h"

namespace cpmesh::cli {

namespace {

nlohmann::json triangle_json(const mesh::TriangleStats& s) {
  return {{"triangles", s.triangles}, {"mean_radius_ratio", s.mean_radius_ratio},
          {"min_radius_ratio", s.min_radius_ratio}, {"share_below_0_5", s.share_below_half}};
}
nlohmann::json tet_json(const mesh::TetStats& s) {
  nlohmann::json j = {{"tets", s.tets}, {"min_dihedral_deg", s.min_dihedral_deg}, {"max_dihedral_deg", s.max_dihedral_deg},
                      {"max_radius_edge", s.max_radius_edge}, {"mean_radius_edge", s.mean_radius_edge}};
  if (s.worst_tet != SIZE_MAX) {  // where the smallest angle is: its index in volume's cells, its centroid
    j["worst_tet"] = s.worst_tet;
    j["worst_tet_centroid"] = {s.worst_centroid.x, s.worst_centroid.y, s.worst_centroid.z};
  }
  return j;
}
nlohmann::json label_map_json(const mesh::WellComposedReport& r) {
  nlohmann::json changes = nlohmann::json::array();
  for (const auto& c : r.labels) changes.push_back({{"label", c.label}, {"gained", c.gained}, {"lost", c.lost}});
  return {{"well_composed_repair", r.applied},
          {"critical_configurations", r.critical_before},
          {"critical_configurations_left", r.critical_left},
          {"voxels_changed", r.voxels_changed},
          {"passes", r.passes},
          {"labels", changes}};
}

}  // namespace

Command add_mesh_command(CLI::App& app, const GlobalOptions& g) {
  struct Options {
    VolumeInput input;
    std::string out;
    std::string format = "vtp";
    std::string volume_format = "vtu";
    mesh::MeshOptions mesh;
    std::vector<std::string> materials;
    std::string preview;
  };
  auto o = std::make_shared<Options>();
  auto* sub = app.add_subcommand(
      "mesh", "Mesh a labeled volume: interface triangle meshes (one per material pair, conforming along triple "
              "curves), a quality tet mesh of every material, the particles and report.json");
  add_volume_input(sub, o->input);
  sub->add_option("-o,--out", o->out, "Output directory (created)")->required();
  sub->add_option("--format", o->format, "Interface mesh format")
      ->check(CLI::IsMember({"vtp", "ply", "obj", "stl"}))
      ->capture_default_str();
  sub->add_option("--volume-format", o->volume_format, "Tet mesh format: vtu, mesh (Medit) or tetgen (.node/.ele/.face)")
      ->check(CLI::IsMember({"vtu", "mesh", "tetgen"}))
      ->capture_default_str();
  auto& m = o->mesh;
  add_fields_options(sub, m.fields);
  add_advection_options(sub, m.advection);
  add_population_options(sub, m.population);
  // TetGen's refinement is only known to end for radius-edge bounds above about 1.1 and dihedral bounds below about
  // 18 degrees (a bound of 1.1/20 ran without end on a 36^3 sphere), so tighter requests are refused.
  sub->add_option("--max-radius-edge", m.volume.max_radius_edge,
                  "Volume mesh: largest tet radius-edge ratio TetGen aims at (>= 1.2); a sliver refilled around a new "
                  "vertex may take its tets up to 1.5 times this")
      ->check(CLI::Range(1.2, 1e6))
      ->capture_default_str();
  sub->add_option("--min-dihedral", m.volume.min_dihedral, "Volume mesh: smallest dihedral angle the sliver passes after TetGen aim at, degrees (<= 18)")
      ->check(CLI::Range(0.0, 18.0))
      ->capture_default_str();
  sub->add_option("--sliver-offset", m.volume.sliver_offset,
                  "Volume mesh: how far the last sliver pass may move an interface vertex off its interface where the "
                  "material is too thin for any place on it, in voxels (0: every vertex stays on its interface)")
      ->check(CLI::Range(0.0, 0.5))
      ->capture_default_str();
  sub->add_option("--min-triangle-ratio", m.volume.min_triangle_ratio,
                  "Volume mesh: the last sliver pass also moves the vertices of interface triangles under this radius "
                  "ratio, where no tet goes under the dihedral bound for it (0: off)")
      ->check(CLI::Range(0.0, 0.5))
      ->capture_default_str();
  sub->add_option("--max-volume", m.volume.max_volume, "Volume mesh: largest tet volume, physical units^3 (0: none)")->capture_default_str();
  sub->add_option("--volume-runs", m.volume.runs,
                  "Volume mesh: TetGen runs to aim at in parallel, materials with large boundaries cut into pieces "
                  "by planes (0: one per thread, see --threads; 1: one run per material, the same mesh on every machine). More runs "
                  "are faster on many cores, and a few more slivers may stay where pieces meet; materials whose cut would cross "
                  "thin layers stay whole")
      ->capture_default_str();
  sub->add_flag("!--no-interior-points", m.volume.interior_points,
               "Volume mesh: TetGen refines from the surface vertices alone, without the interior points of an octree "
               "graded from the surfaces (the same tets within about 1%; on the paper-size head's materials TetGen took "
               "1.35-1.9 times as long without them)");
  sub->add_option("--junction-protection", m.junction_protection,
                  "Leave out interface particles closer than this x h to a triple curve or quadruple point of their "
                  "interface (0: off); keeps junction triangles from degenerating")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  sub->add_option("--min-label-voxels", m.min_label_voxels,
                  "Labels with fewer voxels join the label they touch most (report.json: dropped_labels); 0: keep all")
      ->check(CLI::Range(int64_t(0), int64_t(1) << 40))
      ->capture_default_str();
  sub->add_flag("!--no-well-composed", m.well_composed,
                "Mesh the label map as given; by default voxels of a label that touch only along an edge or at a "
                "corner are first joined across a face, each label changing by at most 1% (report.json: label_map; "
                "docs/design.md, \"Well-composed labels\")");
  sub->add_option("--refinement-rounds", m.repair_rounds,
                  "Rounds of Delaunay refinement where faces are wrong or interfaces not manifold (0: none; a mesh left "
                  "invalid is an error)")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  sub->add_option("--smoothing-rounds", m.smoothing.rounds,
                  "Rounds of interface smoothing after extraction (0: off): interface vertices move towards the "
                  "positions that make their triangles equilateral, curve vertices towards their curve neighbours' "
                  "midpoint; no move takes a triangle below radius ratio 0.3 and below what it was")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  sub->add_option("--collapse-passes", m.collapses.passes,
                  "Passes of edge collapses inside the interfaces after the first smoothing (0: none): a vertex joins a "
                  "neighbour on its feature (or the feature's curve or point) where their edge is under --collapse-length "
                  "x the sizing h and the worst of its triangles gains radius ratio 0.05")
      ->check(CLI::Range(0, 100))
      ->capture_default_str();
  sub->add_option("--collapse-length", m.collapses.max_length,
                  "Longest edge a collapse may remove, as a share of the smaller sizing h at its ends")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  sub->add_option("--flip-passes", m.flips.passes,
                  "Passes of edge flips inside each interface between two smoothings (0: none): an edge is flipped "
                  "where the quad across it is flat within --flip-fold degrees and the worse triangle gains radius ratio 0.02")
      ->check(CLI::Range(0, 100))
      ->capture_default_str();
  sub->add_option("--flip-fold", m.flips.max_fold_deg,
                  "Largest angle between the normals of an edge's two triangles, before and after, for a flip, degrees")
      ->check(CLI::Range(0.0, 90.0))
      ->capture_default_str();
  sub->add_option("--label-volume-tolerance", m.label_volumes.tolerance,
                  "Last, a label (of over 64 voxels, closed) whose interfaces enclose more than this share "
                  "more or less than its voxels grows or shrinks along its normals until they do, by at most a quarter "
                  "voxel (0: off)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  sub->add_flag("--only-surfaces", m.only_surfaces, "Interface meshes only, no tet mesh");
  sub->add_option("--max-particles", m.max_particles,
                  "Stop after seeding, with an error, if it made more particles than this (0: no limit); thin layers "
                  "ask for h at --min-size, so their count grows as 1/min-size^2")
      ->capture_default_str();
  sub->add_option("--preview", o->preview,
                  "Also render the interfaces to this PNG (1200 x 600: an oblique view and the same view cut away at "
                  "the centre, coloured by material pair), offscreen on the same device");
  sub->add_option("--materials", o->materials,
                  "Labels to mesh, comma-separated; A+B merges B into A; labels not listed become 0 (background). "
                  "Example: --materials 1,2+3,4")
      ->delimiter(',');
  return {sub, [o, &g] {
            const bool tty = isatty(STDERR_FILENO) != 0;
            for (const std::string& item : o->materials) {
              std::vector<uint16_t> group;
              size_t start = 0;
              while (start <= item.size()) {
                const size_t plus = std::min(item.find('+', start), item.size());
                const std::string num = item.substr(start, plus - start);
                char* end = nullptr;
                const unsigned long v = std::strtoul(num.c_str(), &end, 10);
                if (num.empty() || *end != '\0' || v > 65535)
                  throw std::invalid_argument("--materials: '" + item + "': expected labels 0..65535 joined by '+'");
                group.push_back(uint16_t(v));
                start = plus + 1;
              }
              o->mesh.materials.push_back(group);
            }
            const auto read_start = std::chrono::steady_clock::now();
            const io::LabelVolume volume = read_volume_input(o->input);
            const double read_seconds =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - read_start).count();
            gpu::Context ctx(g.context());
            // On a terminal: one line per stage, rewritten while it runs.
            bool line_open = false;  // a progress line without its newline yet
            auto on_stage = [&](const mesh::StageEvent& e) {
              if (!tty) return;
              const bool done = e.seconds >= 0;
              char time[32];
              std::snprintf(time, sizeof time, "%.2f s, ", e.seconds);
              stage_line(e.index, e.count, e.stage, done ? time + e.detail : e.detail, done);
              line_open = !done;
            };
            const auto r = [&] {
              try {
                return mesh::mesh_volume(ctx, volume, o->mesh, on_stage);
              } catch (const mesh::ParticleBudgetError& e) {
                if (line_open) std::fputc('\n', stderr);  // the error goes on a line of its own
                throw std::runtime_error(o->input.path + ": " + e.what());
              } catch (...) {
                if (line_open) std::fputc('\n', stderr);
                throw;
              }
            }();
            const auto& rep = r.report;
            const auto write_start = std::chrono::steady_clock::now();
            std::filesystem::create_directories(o->out);
            const std::string dir = o->out + "/";
            io::write_triangle_mesh(dir + "interfaces." + o->format, r.surfaces);
            std::set<std::array<uint16_t, 2>> pairs(r.surfaces.triangle_pair.begin(), r.surfaces.triangle_pair.end());
            for (const auto& pr : pairs) {
              io::TriangleMesh one;
              one.vertices = r.surfaces.vertices;
              one.vertex_feature = r.surfaces.vertex_feature;
              for (size_t i = 0; i < r.surfaces.triangles.size(); ++i)
                if (r.surfaces.triangle_pair[i] == pr) {
                  one.triangles.push_back(r.surfaces.triangles[i]);
                  one.triangle_pair.push_back(pr);
                }
              io::write_triangle_mesh(dir + "interface_" + std::to_string(pr[0]) + "_" + std::to_string(pr[1]) + "." + o->format, one);
            }
            io::write_vtp(dir + "particles.vtp", r.particles);
            if (!r.volume.tets.empty()) {
              if (o->volume_format == "vtu") io::write_vtu(dir + "volume.vtu", r.volume);
              else if (o->volume_format == "mesh") io::write_medit(dir + "volume.mesh", r.volume);
              else io::write_tetgen(dir + "volume", r.volume);
            }
            if (!o->preview.empty()) {
              const auto image = render::rasterize(ctx, render::preview_scene(r.surfaces, 1200, 600));
              io::write_png(o->preview, image.width, image.height, image.rgba);
            }
            // Writing the meshes (the report itself, last, is not counted).
            const double write_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - write_start).count();
            nlohmann::json j;
            j["volume"] = volume.source;
            j["device"] = ctx.info().name;
            j["seconds"] = nlohmann::json::object();
            j["seconds"]["read volume"] = read_seconds;
            for (const auto& [name, s] : rep.seconds) j["seconds"][name] = s;
            j["seconds"]["write"] = write_seconds;
            j["steps"] = nlohmann::json::object();  // parts of a stage: {"fields": {"indicator fields": s, ...}, ...}
            for (const auto& step : rep.steps) j["steps"][step.stage][step.step] = step.seconds;
            j["embedding"] = {{"subcells", rep.subcells}, {"one_subcell_because", rep.one_subcell_because}};
            j["particles"] = rep.particles;
            j["iterations"] = rep.iterations;
            j["rounds"] = rep.rounds;
            j["population_settled"] = rep.settled;
            j["population_steady"] = rep.steady;
            j["surface"] = triangle_json(rep.surface);
            j["surface_at_junctions"] = triangle_json(rep.junction_triangles);
            j["surface_away_from_junctions"] = triangle_json(rep.other_triangles);
            j["protected_particles"] = rep.protected_particles;
            j["off_feature_particles"] = rep.off_feature_particles;
            j["crowded_particles"] = rep.crowded_particles;
            j["smoothing_moves"] = rep.smoothing_moves;
            j["interface_collapses"] = rep.interface_collapses;
            j["interface_flips"] = rep.interface_flips;
            j["label_volumes"] = {{"tolerance", o->mesh.label_volumes.tolerance},
                                  {"labels_moved", rep.label_volumes.labels_moved},
                                  {"moves_undone", rep.label_volumes.moves_undone},
                                  {"moves_refused", rep.label_volumes.moves_refused},
                                  {"worst_error_before", rep.label_volumes.worst_before},
                                  {"worst_error_after", rep.label_volumes.worst_after},
                                  {"worst_label", rep.label_volumes.worst_label}};
            j["repair"] = {{"wrong_faces_before", rep.wrong_faces_before_repair}, {"relabelled_tets", rep.relabelled_tets},
                           {"wrong_faces_after", rep.wrong_faces},
                           {"refinement_points", rep.refinement_points}, {"refinement_rounds", rep.refinement_rounds}};
            j["interfaces"] = nlohmann::json::array();
            for (const auto& ir : rep.interfaces) {
              auto e = triangle_json(ir.quality);
              e["labels"] = ir.labels;
              e["nonmanifold_edges"] = ir.check.nonmanifold_edges;
              e["boundary_edges"] = ir.check.boundary_edges;
              e["open_edges"] = ir.check.open_edges;
              e["manifold"] = ir.check.manifold();
              j["interfaces"].push_back(e);
            }
            j["crossing_triangles"] = rep.crossing_triangles;
            j["nonconforming_faces"] = rep.nonconforming_faces;
            j["materials"] = nlohmann::json::array();
            for (const auto& mr : rep.materials)
              j["materials"].push_back({{"label", mr.label}, {"boundary_triangles", mr.boundary_triangles},
                                        {"odd_edges", mr.odd_edges}, {"closed", mr.odd_edges == 0},
                                        {"volume_mesh", tet_json(mr.tets)}});
            j["volume_mesh"] = tet_json(rep.volume);
            j["volume_mesh"]["min_dihedral_deg_from_tetgen"] = rep.tet_improvement.min_dihedral_before;
            j["volume_mesh"]["sliver_moves"] = rep.tet_improvement.moves;
            j["volume_mesh"]["sliver_flips"] = rep.sliver_split.flips;
            j["volume_mesh"]["sliver_splits"] = rep.sliver_split.inserted;
            j["volume_mesh"]["sliver_cavities_remeshed"] = rep.sliver_split.remeshed;
            j["volume_mesh"]["interface_vertex_moves"] = rep.surface_slivers.moves;
            j["volume_mesh"]["flat_interface_triangles"] = {{"before", rep.surface_slivers.flat_before},
                                                            {"after", rep.surface_slivers.flat_after}};
            j["volume_mesh"]["slivers_left"] = rep.sliver_split.failed;
            j["volume_mesh"]["runs"] = mesh::volume_runs_json(rep);
            j["volume_mesh"]["separator_points"] = rep.volume_separator_points;
            j["volume_mesh"]["unsplit_because"] = rep.volume_unsplit_because;
            j["volume_mesh"]["one_run_because"] = rep.volume_one_run_because;
            if (!rep.volume_error.empty()) j["volume_mesh_error"] = rep.volume_error;
            j["dropped_labels"] = nlohmann::json::array();
            for (const auto& d : rep.dropped_labels)
              j["dropped_labels"].push_back({{"label", d.label}, {"voxels", d.voxels}, {"merged_into", d.merged_into},
                                             {"why", "fewer than " + std::to_string(o->mesh.min_label_voxels) +
                                                         " voxels (--min-label-voxels)"}});
            j["label_map"] = label_map_json(rep.well_composed);
            const std::vector<std::string> failures = mesh::guarantee_failures(rep);
            j["valid"] = failures.empty();
            j["invalid_because"] = failures;
            j["repair"]["refinement_moves"] = rep.refinement_moves;
            j["repair"]["refinement_removals"] = rep.refinement_removals;
            j["repair"]["junction_vertices"] = rep.junction_vertices;
            j["repair"]["mend_fault_edges"] = rep.mend_edges;
            j["repair"]["mend_relabelled_tets"] = rep.mend_relabelled;
            j["repair"]["left"] = nlohmann::json::array();
            for (const auto& left : rep.refinement_left) j["repair"]["left"].push_back({{"labels", left.labels}, {"at", left.at}});
            io::write_atomically(dir + "report.json", [&](std::ostream& out) { out << j.dump(2) << '\n'; });

            std::printf("%s: %zu particles (%d iterations, %zu rounds), %zu interface triangles, %zu tets\n",
                        volume.source.c_str(), rep.particles, rep.iterations, rep.rounds, rep.surface.triangles,
                        rep.volume.tets);
            std::printf("  %-24s %9s\n", "stage", "seconds");
            std::printf("  %-24s %9.2f\n", "read volume", read_seconds);
            double total = read_seconds;
            for (const auto& [name, s] : rep.seconds) {
              std::printf("  %-24s %9.2f\n", name.c_str(), s);
              total += s;
              for (const auto& step : rep.steps)
                if (step.stage == name) std::printf("    %-22s %9.2f\n", step.step.c_str(), step.seconds);
            }
            std::printf("  %-24s %9.2f\n", "write", write_seconds);
            std::printf("  %-24s %9.2f\n", "total", total + write_seconds);
            std::printf("  %-10s %10s %8s %8s %8s %9s\n", "interface", "triangles", "mean rr", "min rr", "<0.5", "manifold");
            for (const auto& ir : rep.interfaces)
              std::printf("  %4u/%-5u %10zu %8.3f %8.3f %7.1f%% %9s\n", ir.labels[0], ir.labels[1], ir.quality.triangles,
                          ir.quality.mean_radius_ratio, ir.quality.min_radius_ratio, 100 * ir.quality.share_below_half,
                          ir.check.manifold() ? "yes" : "no");
            std::printf("  triangles at junctions: %zu, mean radius ratio %.3f; elsewhere: %zu, %.3f\n",
                        rep.junction_triangles.triangles, rep.junction_triangles.mean_radius_ratio,
                        rep.other_triangles.triangles, rep.other_triangles.mean_radius_ratio);
            std::printf("  particles left out: %zu off their feature, %zu crowding a neighbour; junctions: %zu "
                        "interface particles left out (protection); repair: %zu wrong faces, %zu tets relabelled, %zu "
                        "points added by refinement, %zu left\n",
                        rep.off_feature_particles, rep.crowded_particles, rep.protected_particles,
                        rep.wrong_faces_before_repair, rep.relabelled_tets, rep.refinement_points, rep.wrong_faces);
            if (rep.well_composed.critical_before > 0)
              std::printf("  label map: %lld voxels changed at %lld critical configurations (edge- or corner-only "
                          "pairs), %lld left\n",
                          (long long)rep.well_composed.voxels_changed, (long long)rep.well_composed.critical_before,
                          (long long)rep.well_composed.critical_left);
            for (const auto& d : rep.dropped_labels)
              std::printf("  label %u dropped: %lld voxels, fewer than %lld (--min-label-voxels); merged into %u\n",
                          d.label, (long long)d.voxels, (long long)o->mesh.min_label_voxels, d.merged_into);
            std::printf("  all interfaces: mean radius ratio %.3f, min %.3f; %zu of %zu manifold; %zu of %zu materials "
                        "closed; %zu crossing triangle pairs\n",
                        rep.surface.mean_radius_ratio, rep.surface.min_radius_ratio, rep.interfaces_manifold,
                        rep.interfaces.size(), rep.materials_closed, rep.materials.size(), rep.crossing_triangles);
            std::printf("  label volumes (interfaces): worst %.2f%% off (label %d), %.2f%% before %zu labels moved "
                        "to their voxel volume; %zu moves refused by the tets, %zu undone\n",
                        100 * rep.label_volumes.worst_after, rep.label_volumes.worst_label,
                        100 * rep.label_volumes.worst_before, rep.label_volumes.labels_moved,
                        rep.label_volumes.moves_refused, rep.label_volumes.moves_undone);
            if (!o->mesh.only_surfaces) {
              if (rep.volume_error.empty()) {
                std::printf("  volume mesh: %zu tets, dihedral angles %.1f..%.1f deg (%.1f from TetGen, %zu sliver "
                            "moves, %zu flips, %zu splits, %zu cavities remeshed, %zu interface vertex moves; %zu tets left below "
                            "the bound), "
                            "radius-edge max %.2f\n",
                            rep.volume.tets, rep.volume.min_dihedral_deg, rep.volume.max_dihedral_deg,
                            rep.tet_improvement.min_dihedral_before, rep.tet_improvement.moves,
                            rep.sliver_split.flips, rep.sliver_split.inserted, rep.sliver_split.remeshed,
                            rep.surface_slivers.moves, rep.sliver_split.failed, rep.volume.max_radius_edge);
                if (rep.volume.worst_tet != SIZE_MAX)
                  std::printf("  smallest dihedral angle %.3g deg: tet %zu, centroid (%.4g, %.4g, %.4g)\n",
                              rep.volume.min_dihedral_deg, rep.volume.worst_tet, rep.volume.worst_centroid.x,
                              rep.volume.worst_centroid.y, rep.volume.worst_centroid.z);
                for (const auto& run : rep.volume_runs) {
                  std::string who = run.material < rep.materials.size()
                                        ? "material " + std::to_string(rep.materials[run.material].label)
                                        : std::string("all materials");
                  if (run.pieces > 1) who += " " + std::to_string(run.piece + 1) + "/" + std::to_string(run.pieces);
                  std::printf("    %-16s %10zu tets  TetGen %7.2f s, sliver passes %6.2f s\n", who.c_str(), run.tets,
                              run.tetgen, run.slivers);
                }
                for (const auto& why : rep.volume_unsplit_because) std::printf("    %s\n", why.c_str());
              } else
                std::printf("  volume mesh not made: %s\n", rep.volume_error.c_str());
            }
            std::printf("  wrote %s\n", o->out.c_str());
            print_profile(ctx, g);
            // A mesh known to be broken is an error, written out only so that it can be looked at.
            if (!failures.empty()) {
              std::fprintf(stderr, "cpmesh: error: %s: the mesh is not valid; %s holds it for inspection only:\n",
                           o->input.path.c_str(), o->out.c_str());
              for (const auto& f : failures) std::fprintf(stderr, "  %s\n", f.c_str());
              return 1;
            }
            // The surfaces, particles and report are complete and written, but what was asked for is not all there.
            if (!o->mesh.only_surfaces && !rep.volume_error.empty()) {
              std::fprintf(stderr, "cpmesh: error: %s: volume mesh not made (%s); the interface meshes, particles and "
                                   "report.json were written\n",
                           o->input.path.c_str(), rep.volume_error.c_str());
              return 2;
            }
            return 0;
          }};
}

}  // namespace cpmesh::cli
