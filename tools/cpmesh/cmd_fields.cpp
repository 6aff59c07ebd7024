// `cpmesh fields`: the fields stage alone, with everything it computed written out for inspection.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "fields/fields_stage.h"
#include "fields/volume_grid.h"
#include "gpu/describe.h"
#include "io/atomic_file.h"
#include "io/mesh_writers.h"
#include "io/nrrd.h"
#include "progress.h"
#include "volume_input.h"

namespace cpmesh::cli {

namespace {

const char* kind_name(fields::FeatureKind k) {
  switch (k) {
    case fields::FeatureKind::interface: return "interface";
    case fields::FeatureKind::triple_curve: return "triple_curve";
    default: return "quadruple_point";
  }
}

io::FloatVolume float_volume_like(const io::LabelVolume& v) {
  io::FloatVolume f;
  static_cast<io::VolumeGeometry&>(f) = v;
  f.values.assign(size_t(v.voxel_count()), 0.0f);
  return f;
}

}  // namespace

void add_fields_options(CLI::App* sub, fields::FieldsOptions& f) {
  sub->add_option("--sigma", f.indicator.smoothing_sigma, "Antialiasing Gaussian sigma, voxels")->capture_default_str();
  sub->add_option("--tighten", f.indicator.tighten_radius,
                  "Tightening radius r, voxels: smallest curvature radius kept; parts thinner than ~2r are kept as "
                  "they are (0: off)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--island-margin", f.indicator.island_margin,
                  "At the voxels of islands (thin parts of at most 64 voxels, face-connected), every material's field "
                  "keeps at least this many voxels from 0, so the smoothing cannot flatten them into slivers "
                  "(0: the sign only)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 0.49));
  sub->add_flag("!--no-curvature-correction", f.indicator.curvature_correction,
                "Keep the smoothing's shrinkage of curved surfaces (by sigma^2 x mean curvature; corrected by default)");
  sub->add_option("--junction-correction", f.indicator.junction_correction,
                  "Raise each material's field near triple curves by this many voxels times a function of its wedge "
                  "angle, against the smoothing's pull of curves towards flat sides (0: off; at 0.4 the wedge ball's mesh "
                  "curves lie 0.24 instead of 0.31 voxel off on average, for about 10% more particles)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--curve-smoothing", f.embedding.curve_smoothing,
                  "Sigma, voxels, of the local quadratic fit that smooths triple curves along themselves; the fields "
                  "near the curves are moved with them (0: off)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  sub->add_flag("!--no-junction-extrapolation", f.embedding.junction_extrapolation,
                "Before that fit, do not move T-junction curve points (a surface ending on another) to where their "
                "interfaces, extended from 2.5-6 voxels away, meet (on by default: the wedge ball's mesh curves lie "
                "0.12 instead of 0.23 voxel off on average at 48^3)");
  sub->add_option("--band", f.indicator.band,
                  "Narrow band of the indicator fields, voxels (0: 4, or deeper where the embedding needs it)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--subcells", f.embedding.sub,
                  "Closest point embedding: fine points per voxel and axis (1/S; 0: 1 when --min-size is at least a "
                  "voxel and thin parts are at most 2% of the label boundary, else 2)")
      ->check(CLI::Range(0, 4))
      ->capture_default_str();
  sub->add_option("--density", f.sizing.density, "Sizing: h = density x local feature size")->capture_default_str();
  sub->add_option("--min-size", f.sizing.h_min, "Smallest h, physical units (0: a quarter voxel)")->capture_default_str();
  sub->add_option("--max-size", f.sizing.h_max, "Largest h, physical units (0: 4 voxels)")->capture_default_str();
  sub->add_option("--grading", f.sizing.grading, "Lipschitz bound of h")->capture_default_str();
}

void add_advection_options(CLI::App* sub, particles::AdvectionOptions& a) {
  sub->add_option("--theta", a.theta, "Barnes-Hut opening angle (0: exact walk)")->capture_default_str();
  sub->add_option("--skin", a.neighbour_skin,
                  "Verlet neighbour lists: their reach beyond the energy's support, a share of h (0: walk the octree "
                  "every iteration; the exact walk only)")
      ->check(CLI::Range(0.0, 4.0))
      ->capture_default_str();
  sub->add_option("--delta", a.delta, "Stop rule: relative energy decrease per iteration (paper: 0.0015)")->capture_default_str();
}

Command add_fields_command(CLI::App& app, const GlobalOptions&) {
  struct Options {
    VolumeInput input;
    std::string out;
    fields::FieldsOptions fields;
    bool no_volumes = false;
  };
  auto o = std::make_shared<Options>();
  auto* sub = app.add_subcommand(
      "fields", "Build the indicator fields, closest point embedding and sizing field of a volume and write them for "
                "inspection (NRRD volumes, a VTK point cloud of closest points, fields.json)");
  add_volume_input(sub, o->input);
  sub->add_option("-o,--out", o->out, "Output directory (created)")->required();
  add_fields_options(sub, o->fields);
  sub->add_flag("--no-volumes", o->no_volumes, "Skip the per-material NRRD volumes (large for big inputs)");
  return {sub, [o] {
            Progress progress(5);
            io::LabelVolume input = progress.stage("read volume", [&] { return read_volume_input(o->input); });
            const double padding = fields::face_padding(o->fields, input);
            const io::LabelVolume volume = fields::close_at_faces(std::move(input), padding);
            const fields::Grid grid = fields::grid_of(volume);
            auto r = progress.stage("fields: indicator, embedding, sizing",
                                    [&] { return fields::build_fields(grid, volume.labels.data(), o->fields); });
            std::filesystem::create_directories(o->out);
            const std::string dir = o->out + "/";
            const auto& E = r.embedding;
            const int per_block = E.sub * E.sub * E.sub;

            progress.stage("write volumes", [&] {
              if (o->no_volumes) return;
              for (size_t m = 0; m < r.fields.material_count(); ++m) {
                io::FloatVolume v = float_volume_like(volume);
                for (int k = 0; k < grid.dims.z; ++k)
                  for (int j = 0; j < grid.dims.y; ++j)
                    for (int i = 0; i < grid.dims.x; ++i) v.values[grid.index(i, j, k)] = r.fields.fields[m].at(i, j, k);
                io::write_nrrd(dir + "indicator_" + std::to_string(r.fields.labels[m]) + ".nrrd", v, true);
              }
              io::FloatVolume sizing = float_volume_like(volume);  // smallest h of the cell's fine points, 0 off band
              for (size_t slot = 0; slot < E.keys.size(); ++slot) {
                if (E.keys[slot] == fields::ClosestPointEmbedding::kEmpty) continue;
                float& cell = sizing.values[size_t(E.keys[slot] >> 16)];
                for (int q = 0; q < per_block; ++q) {
                  const float h = E.fine[size_t(E.blocks[slot]) * size_t(per_block) + size_t(q)].w;
                  cell = cell == 0.0f ? h : std::min(cell, h);
                }
              }
              io::write_nrrd(dir + "sizing.nrrd", sizing, true);
            });

            progress.stage("write embedding", [&] {
              // One point per block whose cell touches its feature: the stored closest point, its feature and h.
              io::TriangleMesh cloud;
              std::vector<float> feature_id, h;
              for (size_t slot = 0; slot < E.keys.size(); ++slot) {
                if (E.keys[slot] == fields::ClosestPointEmbedding::kEmpty) continue;
                if (!E.touches_feature(size_t(E.keys[slot] >> 16), E.blocks[slot])) continue;
                const glm::vec4 p = E.fine[size_t(E.blocks[slot]) * size_t(per_block)];
                const glm::dvec3 phys = grid.to_physical(glm::dvec3(glm::vec3(p)));
                cloud.vertices.push_back({phys.x, phys.y, phys.z});
                const uint32_t fid = uint32_t(E.keys[slot] & 0xffff);
                cloud.vertex_feature.push_back(uint8_t(E.features[fid].kind));
                feature_id.push_back(float(fid));
                h.push_back(p.w);
              }
              cloud.vertex_scalars = {{"feature_id", feature_id}, {"sizing", h}};
              io::write_vtp(dir + "embedding.vtp", cloud);
            });

            const auto& rep = r.report;
            nlohmann::json j;
            progress.stage("write fields.json", [&] {
              j["volume"] = volume.source;
              j["dims"] = volume.dims;
              j["spacing"] = volume.spacing;
              j["materials"] = r.fields.labels;
              j["tightening"] = {{"radius_voxels", o->fields.indicator.tighten_radius},
                                 {"protected_voxels", r.fields.protected_voxels},
                                 {"voxels_moved_per_material", r.fields.tightened_voxels}};
              j["features"] = nlohmann::json::array();
              for (size_t i = 0; i < E.features.size(); ++i) {
                const auto& feat = E.features[i];
                std::vector<uint16_t> labels;
                for (int a = 0; a < feat.material_count(); ++a) labels.push_back(r.fields.labels[feat.materials[size_t(a)]]);
                j["features"].push_back({{"id", i}, {"kind", kind_name(feat.kind)}, {"labels", labels},
                                         {"components", feat.components}});
              }
              j["quadruple_points"] = nlohmann::json::array();
              for (const auto& q : E.quadruple_points) {
                const glm::dvec3 p = grid.to_physical(q.position);
                j["quadruple_points"].push_back({{"feature", q.feature}, {"position", {p.x, p.y, p.z}}});
              }
              j["seconds"] = {{"indicator", rep.indicator_seconds}, {"embedding", rep.embedding_seconds},
                              {"sizing", rep.sizing_seconds}};
              j["bytes"] = {{"indicator_fields", rep.indicator_bytes}, {"embedding", rep.embedding_bytes}};
              j["embedding"] = {{"subcells", E.sub}, {"blocks", E.block_count()}, {"fine_points", E.stats.fine_points},
                                 {"failed_points", E.stats.failed_points}, {"newton_steps", E.stats.newton_steps}};
              j["curve_smoothing"] = {{"sigma_voxels", o->fields.embedding.curve_smoothing},
                                      {"curve_points", rep.curve_smoothing.curve_points},
                                      {"moved_points", rep.curve_smoothing.moved_points},
                                      {"junction_extrapolation", o->fields.embedding.junction_extrapolation},
                                      {"extrapolated_points", rep.curve_smoothing.extrapolated_points},
                                      {"largest_move_voxels", rep.curve_smoothing.largest_move},
                                      {"changed_field_values", rep.curve_smoothing.changed_values}};
              j["sizing"] = {{"min", rep.sizing.h_min}, {"mean", rep.sizing.h_mean}, {"max", rep.sizing.h_max},
                             {"curvature_limited", rep.sizing.curvature_limited},
                             {"thickness_limited", rep.sizing.thickness_limited}, {"clamped", rep.sizing.clamped}};
              io::write_atomically(dir + "fields.json", [&](std::ostream& out) { out << j.dump(2) << '\n'; });
            });

            std::printf("%s: %zu materials, %zu interfaces, %zu triple curves, %zu quadruple points\n",
                        volume.source.c_str(), r.fields.material_count(), rep.interfaces, rep.triple_curves,
                        rep.quadruple_points);
            std::printf("  %-26s %9s %12s\n", "stage", "seconds", "memory");
            std::printf("  %-26s %9.2f %12s\n", "indicator fields", rep.indicator_seconds,
                        gpu::format_bytes(rep.indicator_bytes).c_str());
            std::printf("  %-26s %9.2f %12s\n", "closest point embedding", rep.embedding_seconds,
                        gpu::format_bytes(rep.embedding_bytes).c_str());
            std::printf("  %-26s %9.2f %12s\n", "sizing field", rep.sizing_seconds, "(in embedding)");
            for (const auto& [name, s] : progress.times())
              if (name.rfind("write", 0) == 0 || name == "read volume") std::printf("  %-26s %9.2f\n", name.c_str(), s);
            uint64_t moved = 0;
            for (auto v : r.fields.tightened_voxels) moved += v;
            std::printf("  tightening r = %g voxel: %llu voxel centres changed material, %llu voxels in thin parts kept\n",
                        o->fields.indicator.tighten_radius, (unsigned long long)moved,
                        (unsigned long long)r.fields.protected_voxels);
            std::printf("  curve smoothing sigma = %g voxel: %zu of %zu curve points moved (%zu at T-junctions), by %.2f voxel "
                        "at most\n",
                        o->fields.embedding.curve_smoothing, rep.curve_smoothing.moved_points,
                        rep.curve_smoothing.curve_points, rep.curve_smoothing.extrapolated_points,
                        rep.curve_smoothing.largest_move);
            const auto& stats = r.embedding.stats;
            const double fine = double(std::max<uint64_t>(stats.fine_points, 1));
            std::printf("  embedding: %d subcells, %llu fine points, %.1f%% with no closest point found (thin layers), "
                        "%.1f Newton steps per point\n",
                        r.embedding.sub, (unsigned long long)stats.fine_points, 100.0 * stats.failed_share(),
                        double(stats.newton_steps) / fine);
            std::printf("  sizing h: min %.3g, mean %.3g, max %.3g (physical units)\n", rep.sizing.h_min,
                        rep.sizing.h_mean, rep.sizing.h_max);
            std::printf("  wrote %s\n", o->out.c_str());
            return 0;
          }};
}

}  // namespace cpmesh::cli
