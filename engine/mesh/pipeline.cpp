#include "mesh/pipeline.h"
#include "mesh/mend_topology.h"
#include "mesh/refine.h"
#include "mesh/small_labels.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <optional>
#include <tuple>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "fields/device_fields.h"
#include "fields/volume_grid.h"
#include "mesh/delaunay.h"
#include "mesh/extract.h"
#include "mesh/smooth.h"
#include "mesh/surface_slivers.h"
#include "mesh/volume_mesh.h"
#include "ref/cp_lookup.h"

namespace cpmesh::mesh {

namespace {
// Particles farther than this share of their h from their feature are left out (particles::drop_off_feature), after
// every add/delete round and once more after the last run. On the
// 48^3 wedge ball the farthest particle lies 0.007 h off; on the 160^3 head proxy 99% lie within 0.017 h, and 0.5%
// from 0.05 h to hundreds of h (where both of an interface's fields are clamped at the band's depth).
constexpr double kOffFeatureShare = 0.25;

// Particles closer than this share of their h to an earlier particle of their feature are left out
// (particles::thin_crowded). The energy keeps neighbours about h apart and the add/delete rounds delete crowded
// particles (energy above delete_factor x the ideal), so only a feature too small for its particles keeps pairs this
// close (islands-48: 68 of 1613 particles).
constexpr double kCrowdedShare = 0.5;

// The interfaces' quality and topology (report fields surface, junction_triangles, other_triangles,
// crossing_triangles, interfaces, materials and their counts) from the interface mesh as it is now.
void interface_quality(const InterfaceMesh& I, const std::vector<uint8_t>& kind, const std::vector<uint16_t>& labels,
                       MeshReport& rep) {
  rep.interfaces.clear();
  rep.materials.clear();
  rep.interfaces_manifold = rep.materials_closed = 0;
  std::vector<uint8_t> on_curve(kind.size());
  for (size_t v = 0; v < kind.size(); ++v) on_curve[v] = kind[v] != uint8_t(fields::FeatureKind::interface);
  // The interfaces (material pairs, in order) and each triangle's: radius-ratio sums per interface and per side of
  // the junctions (a triangle with a curve or point vertex) in one pass, every edge check in one sort.
  std::vector<std::array<uint16_t, 2>> pairs(I.pair.begin(), I.pair.end());
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  std::vector<uint32_t> pair_index(I.triangles.size()), sums_group(I.triangles.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, I.triangles.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      const auto& tri = I.triangles[i];
      pair_index[i] = uint32_t(std::lower_bound(pairs.begin(), pairs.end(), I.pair[i]) - pairs.begin());
      sums_group[i] = 2 * pair_index[i] + uint32_t(on_curve[tri[0]] || on_curve[tri[1]] || on_curve[tri[2]]);
    }
  });
  const std::vector<TriangleSums> sums = triangle_sums_by_group(I.vertices, I.triangles, sums_group, 2 * pairs.size());
  TriangleSums all, at_junction, away;
  for (size_t g = 0; g < pairs.size(); ++g) {
    away += sums[2 * g];
    at_junction += sums[2 * g + 1];
  }
  all += away;
  all += at_junction;
  rep.surface = all.stats();
  rep.junction_triangles = at_junction.stats();
  rep.other_triangles = away.stats();
  rep.crossing_triangles = crossing_triangles(I.vertices, I.triangles).size();
  const EdgeChecks edges = check_edges(I.triangles, pair_index, pairs, labels.size(), on_curve);
  for (size_t g = 0; g < pairs.size(); ++g) {
    InterfaceReport ir;
    ir.labels = {labels[pairs[g][0]], labels[pairs[g][1]]};
    TriangleSums both = sums[2 * g];
    both += sums[2 * g + 1];
    ir.quality = both.stats();
    ir.check = edges.interfaces[g];
    rep.interfaces_manifold += ir.check.manifold();
    rep.interfaces.push_back(ir);
  }
  for (size_t m = 0; m < labels.size(); ++m) {
    MaterialReport mr;
    mr.label = labels[m];
    for (size_t g = 0; g < pairs.size(); ++g)
      if (pairs[g][0] == m || pairs[g][1] == m) mr.boundary_triangles += sums[2 * g].triangles + sums[2 * g + 1].triangles;
    mr.odd_edges = edges.odd_edges[m];
    rep.materials_closed += mr.odd_edges == 0;
    rep.materials.push_back(mr);
  }
}

std::vector<std::array<double, 3>> physical_vertices(const fields::Grid& grid, const std::vector<glm::dvec3>& local) {
  std::vector<std::array<double, 3>> out(local.size());
  for (size_t v = 0; v < local.size(); ++v) {
    const glm::dvec3 q = grid.to_physical(local[v]);
    out[v] = {q.x, q.y, q.z};
  }
  return out;
}

// surface_slivers.h over the volume mesh V, the interface vertices (the first points of V, those of I) moving on their
// interfaces by the fields' projection (smooth.h onto_feature); I takes their new positions.
SurfaceSliverReport mend_surface_slivers(const fields::FieldsResult& F, const std::vector<uint32_t>& vertex_feature,
                                         const std::vector<uint8_t>& kind, const QualityOptions& options,
                                         double voxel, InterfaceMesh& I, Tets& V) {
  // A vertex promoted to a junction (extract.h) moves as a quadruple point does, by the offset alone: its feature is
  // not the junction it stands for.
  std::vector<uint8_t> movable(I.vertices.size());
  for (size_t v = 0; v < movable.size(); ++v) {
    const auto own = F.embedding.features[vertex_feature[v]].kind;
    movable[v] = kind[v] != uint8_t(own)                      ? 3
                 : own == fields::FeatureKind::interface     ? 1
                 : own == fields::FeatureKind::triple_curve  ? 2
                                                             : 3;
  }
  const FeatureProjection project = [&](uint32_t v, const glm::dvec3& near, glm::dvec3& on) {
    return onto_feature(F.fields, F.embedding, vertex_feature[v], near, V.points[v], on);
  };
  const SurfaceMoveOptions moves{.target_deg = options.min_dihedral,
                                 .max_radius_edge = options.max_radius_edge,
                                 .max_offset = options.sliver_offset * voxel,
                                 .min_ratio = options.min_triangle_ratio};
  SurfaceSliverReport r = move_surface_vertices(V.points, V.tets, I.triangles, movable, project, moves);
  // The inner vertices around the moved ones may find better places now, and then the moved ones again.
  for (int round = 0; round < 3 && r.moves > 0 && (r.slivers_after > 0 || r.flat_after > 0); ++round) {
    improve_tets(V.points, V.tets, I.vertices.size(), options.min_dihedral, options.max_radius_edge);
    const SurfaceSliverReport again = move_surface_vertices(V.points, V.tets, I.triangles, movable, project, moves);
    r.slivers_after = again.slivers_after;
    r.flat_after = again.flat_after;
    if (again.moves == 0) break;
    r.moves += again.moves;
  }
  if (r.moves > 0) std::copy_n(V.points.begin(), I.vertices.size(), I.vertices.begin());
  return r;
}
}  // namespace

io::LabelVolume select_materials(const io::LabelVolume& volume, const std::vector<std::vector<uint16_t>>& groups) {
  io::LabelVolume out = volume;
  if (groups.empty()) return out;
  std::vector<uint8_t> present(65536, 0);
  for (uint16_t l : volume.labels) present[l] = 1;
  std::vector<uint16_t> map(65536, 0);
  for (const auto& g : groups)
    for (uint16_t l : g) {
      if (!present[l]) {
        std::string have;
        for (size_t v = 0; v < present.size(); ++v) {
          if (!present[v]) continue;
          if (!have.empty()) have.push_back(',');
          have.append(std::to_string(v));
        }
        throw std::invalid_argument(volume.source + ": materials: label " + std::to_string(l) +
                                    " is not in the volume (its labels: " + have + ")");
      }
      map[l] = g.front();
    }
  for (auto& l : out.labels) l = map[l];
  return out;
}

void check_label_limit(const io::LabelVolume& v, const LabelCensus& census) {
  size_t count = census[0] > 0 ? 0 : 1;  // the outside is label 0
  for (int64_t voxels : census) count += voxels > 0;
  if (count > kMaxMaterials)
    throw std::invalid_argument(v.source + ": " + std::to_string(count) + " materials (the labels and the outside, label 0); "
                                "cpmesh supports at most " + std::to_string(kMaxMaterials) +
                                " (merge or drop labels with --materials)");
}

namespace {

// Per material: its voxels' volume in the volume meshed (before the well-composed pass, which trades voxels between
// labels to make the map well-composed, not to change what they are).
std::vector<double> label_volume_targets(const LabelCensus& census, const std::vector<uint16_t>& labels,
                                         const fields::Grid& grid) {
  std::vector<double> target(labels.size());
  for (size_t m = 0; m < labels.size(); ++m)
    target[m] = double(census[labels[m]]) * grid.spacing.x * grid.spacing.y * grid.spacing.z;
  return target;
}

// Per material: 1 where its volume is measured (label_volumes.h): it has at least min_voxels voxels and no region of
// it reaches the Delaunay hull (the background around the padded volume does).
std::vector<uint8_t> bounded_labels(const Adjacency& adj, const std::vector<uint16_t>& hull,
                                    const std::vector<uint16_t>& material, const LabelCensus& census,
                                    const std::vector<uint16_t>& labels, uint64_t min_voxels) {
  std::vector<uint8_t> bounded(labels.size());
  for (size_t m = 0; m < labels.size(); ++m) bounded[m] = census[labels[m]] >= int64_t(min_voxels);
  for (size_t tc = 0; tc < adj.neighbour.size(); ++tc)
    if (opens_to_outside(adj, hull, material, uint32_t(tc))) bounded[material[tc / 4]] = 0;
  return bounded;
}

}  // namespace

MeshResult mesh_volume(gpu::Context& ctx, const io::LabelVolume& input, const MeshOptions& options,
                       const StageCallback& on_stage) {
  MeshResult result;
  MeshReport& rep = result.report;
  const io::LabelVolume selected = options.materials.empty() ? io::LabelVolume{} : select_materials(input, options.materials);
  const io::LabelVolume& chosen = options.materials.empty() ? input : selected;
  const LabelCensus census = label_census(chosen);
  rep.dropped_labels = small_labels(chosen, census, options.min_label_voxels);
  io::LabelVolume meshed = rep.dropped_labels.empty() ? chosen : merge_labels(chosen, rep.dropped_labels);
  check_label_limit(meshed, merge_labels(census, rep.dropped_labels));  // in a moment, not after the fields
  const LabelCensus meshed_census = label_census(meshed);  // what each label's volume should be
  if (options.well_composed) rep.well_composed = make_well_composed(meshed);
  using clock = std::chrono::steady_clock;
  auto t = clock::now();
  const int stage_count = options.only_surfaces ? 6 : 7;
  int stage_index = 0;
  std::string current;
  auto begin = [&](const std::string& name) {
    current = name;
    ++stage_index;
    if (on_stage) on_stage({name, stage_index, stage_count, {}, -1});
  };
  auto update = [&](const std::string& detail) {
    if (on_stage) on_stage({current, stage_index, stage_count, detail, -1});
  };
  auto stage_done = [&](const std::string& detail) {
    const auto now = clock::now();
    const double s = std::chrono::duration<double>(now - t).count();
    rep.seconds.emplace_back(current, s);
    t = now;
    if (on_stage) on_stage({current, stage_index, stage_count, detail, s});
  };
  auto count = [](size_t n) {  // 12345678 -> "12,345,678"
    const std::string digits = std::to_string(n);
    std::string s;
    for (size_t i = 0; i < digits.size(); ++i) {
      if (i > 0 && (digits.size() - i) % 3 == 0) s += ',';
      s += digits[i];
    }
    return s;
  };

  begin("fields");
  const fields::DeviceFields device_fields = fields::build_device_fields(ctx, meshed, options.fields);
  const io::LabelVolume& volume = device_fields.volume;
  for (int a = 0; a < 3; ++a) rep.face_padding[a] = (volume.dims[a] - input.dims[a]) / 2;
  const fields::Grid grid = fields::grid_of(volume);
  const auto& F = device_fields.fields;
  rep.steps.push_back({"fields", "indicator fields", F.report.indicator_seconds});
  rep.steps.push_back({"fields", "embedding", F.report.embedding_seconds});
  rep.steps.push_back({"fields", "sizing field", F.report.sizing_seconds});
  {
    char d[384], thin[96] = "";
    rep.subcells = F.embedding.sub;
    rep.one_subcell_because = device_fields.one_subcell_because;
    rep.band_voxels = F.fields.band / grid.min_spacing();
    const auto& stats = F.embedding.stats;
    if (stats.failed_points > 0)
      std::snprintf(thin, sizeof thin, ", %.1f%% of its points with no closest point found (thin layers)",
                    100.0 * stats.failed_share());
    std::snprintf(d, sizeof d,
                  "%zu interfaces, %zu triple curves, %zu quadruple points; sizing h %.3g..%.3g; embedding %d subcells, "
                  "band %.3g voxels%s%s%s",
                  F.report.interfaces, F.report.triple_curves, F.report.quadruple_points, F.report.sizing.h_min,
                  F.report.sizing.h_max, rep.subcells, rep.band_voxels,
                  rep.one_subcell_because.empty() ? "" : " (two would not fit the device)", thin,
                  rep.face_padding[0] > 0 ? "; labels on the volume's faces: closed by label 0 outside" : "");
    stage_done(d);
  }
  const auto& labels = F.fields.labels;

  begin("seeding");
  const auto seeds = particles::seed_population(F.embedding, options.population);
  if (options.max_particles > 0 && seeds.particles.size() > options.max_particles) {
    char d[400];
    std::snprintf(d, sizeof d,
                  "seeding made %s particles, more than the limit of %s (sizing h %.3g..%.3g, physical units; h stops "
                  "at the smallest size where thin layers or tight curvature ask for less): raise --min-size, "
                  "--max-size or --max-particles",
                  count(seeds.particles.size()).c_str(), count(options.max_particles).c_str(), F.report.sizing.h_min,
                  F.report.sizing.h_max);
    throw ParticleBudgetError(d);
  }
  stage_done(count(seeds.particles.size()) + " particles");

  begin("advection");
  int iterations_so_far = 0;
  const auto drop_off_feature = [&](particles::Population& P) {
    return particles::drop_off_feature(F.fields, F.embedding, P, kOffFeatureShare);
  };
  auto relaxed = particles::relax(ctx, F.embedding, seeds,
                                  particles::with_sizing_grading(options.advection, options.fields.sizing.grading),
                                  options.population,
                                  [&](const particles::RoundReport& r) {
                                    iterations_so_far += r.iterations;
                                    char times[96];
                                    std::snprintf(times, sizeof times, " (this run %.1f s, check %.1f s, add/delete %.1f s)",
                                                  r.advect_seconds, r.check_seconds, r.host_seconds);
                                    update("round " + std::to_string(r.round) + ", " + count(r.total) + " particles, " +
                                           std::to_string(iterations_so_far) + " iterations" + times);
                                  },
                                  drop_off_feature);
  for (const auto& r : relaxed.rounds) rep.off_feature_particles += r.pruned;
  rep.off_feature_particles += drop_off_feature(relaxed.population);
  rep.crowded_particles = particles::thin_crowded(F.embedding, relaxed.population, kCrowdedShare);
  rep.protected_particles =
      particles::protect_junctions(F.fields, F.embedding, relaxed.population, options.junction_protection);
  stage_done(count(relaxed.population.particles.size()) + " particles, " + std::to_string(relaxed.iterations) +
             " iterations, " + std::to_string(relaxed.rounds.size()) + " rounds" +
             (relaxed.settled ? ", settled" : relaxed.steady ? ", steady" : ", not settled"));
  const auto& P = relaxed.population;
  rep.particles = P.particles.size();
  rep.rounds = relaxed.rounds.size();
  rep.iterations = relaxed.iterations;
  rep.settled = relaxed.settled;
  rep.steady = relaxed.steady;

  std::vector<glm::dvec3> points;
  std::vector<uint8_t> kind;
  std::vector<fields::MaterialList> vertex_materials;
  std::vector<float> vertex_h;
  std::vector<uint32_t> vertex_feature;
  auto set_vertex = [&](size_t v, const glm::dvec3& p, uint32_t f, float h) {
    const auto& feat = F.embedding.features[f];
    points[v] = p;
    vertex_feature[v] = f;
    kind[v] = uint8_t(feat.kind);
    vertex_materials[v] = feat.material_set();
    vertex_h[v] = h;
  };
  auto add_vertex = [&](const glm::dvec3& p, uint32_t f, float h) {
    points.emplace_back();
    vertex_feature.emplace_back();
    kind.emplace_back();
    vertex_materials.emplace_back();
    vertex_h.emplace_back();
    set_vertex(points.size() - 1, p, f, h);
  };
  std::vector<uint8_t> moved;  // points the refinement moved: they stay where they went
  auto remove_vertices = [&](std::vector<uint32_t> gone) {
    if (gone.empty()) return;
    std::sort(gone.begin(), gone.end());
    size_t kept = 0, g = 0;
    for (size_t v = 0; v < points.size(); ++v) {
      if (g < gone.size() && gone[g] == v) {
        ++g;
        continue;
      }
      std::tie(points[kept], kind[kept], vertex_materials[kept], vertex_h[kept], vertex_feature[kept], moved[kept]) =
          std::tie(points[v], kind[v], vertex_materials[v], vertex_h[v], vertex_feature[v], moved[v]);
      ++kept;
    }
    points.resize(kept), kind.resize(kept), vertex_materials.resize(kept), vertex_h.resize(kept);
    vertex_feature.resize(kept), moved.resize(kept);
  };
  for (size_t i = 0; i < P.particles.size(); ++i)
    add_vertex(glm::dvec3(glm::vec3(P.particles[i])), P.features[i], P.particles[i].w);
  moved.assign(points.size(), 0);
  const std::vector<uint32_t> clustered = clustered_junction_points(points, kind, vertex_h, grid.min_spacing());
  rep.refinement_removals += clustered.size();
  remove_vertices(clustered);

  // Delaunay, labels, repair, then Delaunay refinement (refine.h): where wrong faces are left or an interface is not
  // a manifold bounded by triple curves, samples are added on the missing features (inserted into the
  // tetrahedralization: DelaunayMesh::insert; rebuilt where points moved) and the tets labelled again, until none
  // is needed or none fits; the faults then left are mended by relabelling runs of tets around them
  // (mend_topology.h).
  begin("delaunay and extraction");
  double tetrahedralization_seconds = 0;  // the rest of the stage (from its start) is the extraction
  const auto stage_start = t;             // when the stage began (the last stage_done)
  auto timed = [&](auto&& step) {
    const auto s0 = clock::now();
    step();
    tetrahedralization_seconds += std::chrono::duration<double>(clock::now() - s0).count();
  };
  std::optional<DelaunayMesh> delaunay_mesh;  // kept for the refinement's insertions
  Tets T;
  Adjacency adj;
  timed([&] {
    delaunay_mesh.emplace(points);
    T = delaunay_mesh->tets(&adj);
  });
  std::vector<uint16_t> material, hull;
  std::pair<size_t, size_t> fewest_faces{SIZE_MAX, SIZE_MAX};
  int stalled = 0;
  // The round with the fewest faces to refine: where later rounds made it worse (samples crowding a thin sheet's
  // two sides), the refinement ends with that round's mesh.
  struct Best {
    Tets T;
    Adjacency adj;
    std::vector<uint16_t> material, hull;
    std::vector<glm::dvec3> points;
    std::vector<uint8_t> kind;
    std::vector<fields::MaterialList> vertex_materials;
    std::vector<float> vertex_h;
    std::vector<uint32_t> vertex_feature;
    MeshReport report;
  } best;
  // The faces to mend (the wrong ones, and those around interface edges that are not manifold) and their sites; the
  // report lists where the first of them lie. Once there are none, those around pinched junction vertices
  // (refine.h, pinched_vertex_faces), which are no part of the guarantee: the refinement reaches the guarantee as it
  // would without them, then refines them, and a round that breaks the guarantee for them is not kept.
  struct FacesToMend {
    std::vector<RefineSite> sites;
    std::pair<size_t, size_t> count;  // the guarantee's faces, then the pinched vertices'; rounds compare by both
  };
  auto faces_to_mend = [&](const std::vector<uint32_t>& wrong) {
    const InterfaceMesh I = extract_interfaces(T, adj, hull, material, kind);
    std::vector<uint32_t> faces = nonmanifold_faces(I);
    faces.insert(faces.end(), wrong.begin(), wrong.end());
    const size_t guarantee = faces.size();
    if (guarantee == 0) faces = pinched_vertex_faces(I);
    std::vector<RefineSite> sites = face_sites(F.fields, T, adj, hull, material, vertex_materials, faces);
    rep.refinement_left.clear();
    for (size_t i = 0; i < guarantee && i < kMaxRefinementLeft; ++i) {
      const glm::dvec3 q = grid.to_physical(sites[i].at);
      rep.refinement_left.push_back({{labels[sites[i].m], labels[sites[i].o]}, {q.x, q.y, q.z}});
    }
    return FacesToMend{std::move(sites), {guarantee, guarantee > 0 ? 0 : faces.size()}};
  };
  for (int round = 0;; ++round) {
    material = label_tets(F.fields, T);
    hull = hull_materials(F.fields, T, adj);
    if (round == 0) rep.wrong_faces_before_repair = wrong_faces(T, adj, hull, vertex_materials, material).size();
    rep.relabelled_tets += repair_labels(T, adj, hull, vertex_materials, material);
    auto wrong = wrong_faces(T, adj, hull, vertex_materials, material);
    for (int pass = 0; pass < 3 && !wrong.empty() &&
                       widen_to_near_junctions(F.fields, F.embedding, T, adj, hull, material, wrong, vertex_h, vertex_materials) > 0;
         ++pass) {
      rep.relabelled_tets += repair_labels(T, adj, hull, vertex_materials, material);
      wrong = wrong_faces(T, adj, hull, vertex_materials, material);
    }
    rep.wrong_faces = wrong.size();
    const auto [sites, faces] = faces_to_mend(wrong);
    rep.refinement_rounds = round;
    // A round that leaves more faces to refine than the best round three rounds ago ends it: what is left cycles.
    stalled = faces < fewest_faces ? 0 : stalled + 1;
    update("refinement round " + std::to_string(round) + ": " + count(faces.first) + " faces to mend, " +
           count(faces.second) + " at pinched junctions, " + count(points.size()) + " points");
    bool last = sites.empty() || round == options.repair_rounds || stalled == 3;
    if (faces < fewest_faces && !last)
      best = {T, adj, material, hull, points, kind, vertex_materials, vertex_h, vertex_feature, rep};
    Refinement extra;
    if (!last)
      extra = refinement_points(F.fields, F.embedding, sites, {points, vertex_materials, vertex_h, moved},
                                options.junction_protection);
    last = last || (extra.added.empty() && extra.moved.empty() && extra.removed.empty());  // no room left
    if (faces > fewest_faces && last) {
      const int rounds = rep.refinement_rounds;
      std::tie(T, adj, material, hull, points, kind, vertex_materials, vertex_h, vertex_feature, rep) =
          std::tie(best.T, best.adj, best.material, best.hull, best.points, best.kind, best.vertex_materials,
                   best.vertex_h, best.vertex_feature, best.report);
      rep.refinement_rounds = rounds;
    }
    fewest_faces = std::min(fewest_faces, faces);
    if (last) break;
    std::vector<glm::dvec3> positions;
    for (const RefinePoint& e : extra.added) {
      add_vertex(e.position, e.feature, e.h);
      positions.push_back(e.position);
    }
    moved.resize(points.size());
    for (const auto& [v, e] : extra.moved) {
      set_vertex(v, e.position, e.feature, e.h);
      moved[v] = 1;
    }
    remove_vertices(extra.removed);
    rep.refinement_points += extra.added.size();
    rep.refinement_moves += extra.moved.size();
    rep.refinement_removals += extra.removed.size();
    timed([&] {
      if (extra.moved.empty() && extra.removed.empty()) delaunay_mesh->insert(positions);
      else delaunay_mesh.emplace(points);  // moved or removed points: the tetrahedralization starts again
      T = delaunay_mesh->tets(&adj);
    });
  }
  delaunay_mesh.reset();
  // The mend, then where wrong faces are left the last resort (refine.h, wrong_vertex_junctions: the vertex takes the
  // junction as its feature where it stands) and the mend again.
  const TopologyMendReport mended = mend_topology(T, adj, hull, vertex_materials, kind, material);
  rep.mend_edges = mended.edges, rep.mend_relabelled = mended.relabelled;
  // The mend adds no wrong faces, so where the last round left none there are none to look for.
  std::vector<uint32_t> wrong;
  if (rep.wrong_faces > 0) wrong = wrong_faces(T, adj, hull, vertex_materials, material);
  const auto joins = wrong_vertex_junctions(F.fields, F.embedding, T, adj, hull, material, wrong, vertex_h, vertex_materials);
  for (const auto& [v, to] : joins) set_vertex(v, points[v], to.feature, vertex_h[v]);
  if (!joins.empty()) {
    rep.mend_relabelled += mend_topology(T, adj, hull, vertex_materials, kind, material).relabelled;
    wrong = wrong_faces(T, adj, hull, vertex_materials, material);
  }
  if (mended.relabelled > 0 || !joins.empty()) {
    rep.wrong_faces = wrong.size();
    faces_to_mend(wrong);
  }
  rep.delaunay_tets = T.tets.size();
  InterfaceMesh I = extract_interfaces(T, adj, hull, material, kind);
  rep.junction_vertices = joins.size() + promote_junction_vertices(I, vertex_materials, kind);
  rep.steps.push_back({"delaunay and extraction", "tetrahedralization", tetrahedralization_seconds});
  rep.steps.push_back({"delaunay and extraction", "extraction",
                       std::max(0.0, std::chrono::duration<double>(clock::now() - stage_start).count() -
                                         tetrahedralization_seconds)});
  stage_done(count(T.tets.size()) + " Delaunay tets, " + count(I.triangles.size()) + " interface triangles, " +
             std::to_string(rep.wrong_faces) + " wrong faces left");

  begin("smoothing");
  rep.smoothing_moves = smooth_interfaces(F.fields, F.embedding, vertex_feature, I, options.smoothing).moves;
  rep.interface_collapses = collapse_interface_edges(I, vertex_h, options.collapses).collapses;
  rep.interface_flips = flip_interface_edges(I, options.flips).flips;
  if (rep.interface_collapses + rep.interface_flips > 0)
    rep.smoothing_moves += smooth_interfaces(F.fields, F.embedding, vertex_feature, I, options.smoothing).moves;
  T.points = I.vertices;  // the volume mesh's region points come from these tets
  // Label volumes (label_volumes.h): on the final vertices, so after the volume mesh's sliver moves where there is one.
  const std::vector<double> volume_targets = label_volume_targets(meshed_census, labels, grid);
  const std::vector<uint8_t> volume_measured =
      bounded_labels(adj, hull, material, meshed_census, labels, options.label_volumes.min_voxels);
  auto match_volumes = [&](const TetsAround& tets) {
    rep.label_volumes = match_label_volumes(I, kind, volume_targets, volume_measured, grid.min_spacing(),
                                            options.label_volumes, tets);
    if (rep.label_volumes.worst_material >= 0)
      rep.label_volumes.worst_label = labels[size_t(rep.label_volumes.worst_material)];
  };
  if (options.only_surfaces) match_volumes({});
  stage_done(count(rep.smoothing_moves) + " vertex moves, " + count(rep.interface_collapses) + " edge collapses, " +
             count(rep.interface_flips) + " edge flips");

  begin("quality");
  interface_quality(I, kind, labels, rep);
  // Outputs in physical units (part of this stage's time).
  result.surfaces.vertices = physical_vertices(grid, I.vertices);
  result.surfaces.triangles = I.triangles;
  for (const auto& pr : I.pair) result.surfaces.triangle_pair.push_back({labels[pr[0]], labels[pr[1]]});
  result.surfaces.vertex_feature = kind;
  result.particles.vertices = result.surfaces.vertices;
  result.particles.vertex_feature = kind;
  result.particles.vertex_scalars = {{"sizing", vertex_h}};

  {
    char d[160];
    std::snprintf(d, sizeof d, "radius ratio mean %.3f, min %.3f; %zu of %zu interfaces manifold%s",
                  rep.surface.mean_radius_ratio, rep.surface.min_radius_ratio, rep.interfaces_manifold,
                  rep.interfaces.size(), rep.crossing_triangles ? "; triangles cross" : "");
    stage_done(d);
  }

  if (!options.only_surfaces) {
    begin("volume mesh");
    const auto volume_start = clock::now();
    std::vector<Region> regions;
    for (uint32_t t : component_representatives(T, adj, hull, material)) {
      glm::dvec3 c(0.0);
      for (uint32_t v : T.tets[t]) c += T.points[v];
      regions.push_back({c / 4.0, int(material[t]) + 1});
    }
    rep.steps.push_back({"volume mesh", "region seeds", std::chrono::duration<double>(clock::now() - volume_start).count()});
    try {
      MaterialMeshes meshes = mesh_materials(I.vertices, I.triangles, I.pair, regions, labels, options.volume);
      const auto moves_start = clock::now();
      rep.surface_slivers = mend_surface_slivers(F, vertex_feature, kind, options.volume, grid.min_spacing(), I,
                                                 meshes.tets);
      {
        const ElementsAround<4> around(meshes.tets.points.size(), meshes.tets.tets);
        match_volumes({&meshes.tets.points, &meshes.tets.tets, &around, options.volume.min_dihedral});
      }
      if (rep.surface_slivers.moves > 0 || rep.label_volumes.labels_moved > 0) {  // the interfaces moved with the tets
        interface_quality(I, kind, labels, rep);
        result.surfaces.vertices = result.particles.vertices = physical_vertices(grid, I.vertices);
      }
      const double moves_seconds = std::chrono::duration<double>(clock::now() - moves_start).count();
      const auto output_start = clock::now();
      rep.tet_improvement = meshes.improvement;
      rep.sliver_split = meshes.sliver_split;
      if (rep.surface_slivers.moves > 0 || rep.label_volumes.labels_moved > 0)
        rep.sliver_split.failed = count_below_dihedral(meshes.tets.points, meshes.tets.tets, options.volume.min_dihedral);
      rep.volume_one_run_because = meshes.one_run_because;
      rep.volume_runs = meshes.runs;
      rep.volume_unsplit_because = meshes.unsplit_because;
      rep.volume_separator_points = meshes.separator_points;
      rep.steps.push_back({"volume mesh", "cutting into pieces", meshes.cut_seconds});
      rep.steps.push_back({"volume mesh", "TetGen runs", meshes.runs_seconds});
      rep.steps.push_back({"volume mesh", "merge and seams", meshes.seam_seconds});
      rep.steps.push_back({"volume mesh", "interface vertex moves", moves_seconds});
      const Tets& V = meshes.tets;
      // The output has only the vertices of its tets: particles left out of the interfaces are in no tet, and FEM
      // readers reject or warn about nodes no element uses.
      auto& out = result.volume;
      // Tets in no seeded region (TetGen numbers an unseeded region itself: the one-run fallback on the 32^3 shells)
      // take their neighbours' material, or their interfaces' side, the fields' only where neither says.
      const std::vector<uint16_t> material_of = tet_materials(V, I.triangles, I.pair, labels.size(),
                                                              [&](uint32_t t) { return label_tet(F.fields, V, t); });
      // Used vertices (of a tet or an interface triangle) keep their order: the interface vertices first, then the
      // points the runs added.
      std::vector<uint8_t> used(V.points.size(), 0);
      tbb::parallel_for(tbb::blocked_range<size_t>(0, V.tets.size()), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i)
          for (uint32_t v : V.tets[i]) std::atomic_ref<uint8_t>(used[v]).store(1, std::memory_order_relaxed);
      });
      for (const auto& t : I.triangles)  // on tets' faces, unless a run left a part out
        for (uint32_t v : t) used[v] = 1;
      std::vector<uint32_t> renumber(V.points.size(), UINT32_MAX);
      uint32_t kept = 0;
      for (size_t v = 0; v < V.points.size(); ++v)
        if (used[v]) renumber[v] = kept++;
      out.vertices.resize(kept);
      out.tets.resize(V.tets.size());
      out.tet_material.resize(V.tets.size());
      tbb::parallel_for(tbb::blocked_range<size_t>(0, V.points.size()), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t v = r.begin(); v != r.end(); ++v)
          if (used[v]) {
            const glm::dvec3 q = grid.to_physical(V.points[v]);
            out.vertices[renumber[v]] = {q.x, q.y, q.z};
          }
      });
      tbb::parallel_for(tbb::blocked_range<size_t>(0, V.tets.size()), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
          const auto& t = V.tets[i];
          out.tets[i] = {renumber[t[0]], renumber[t[1]], renumber[t[2]], renumber[t[3]]};
          out.tet_material[i] = labels[material_of[i]];
        }
      });
      const FaceConformity conformity = nonconforming_faces(V.points, V.tets, material_of, I.triangles, I.pair);
      rep.nonconforming_faces = conformity.mismatches;
      const glm::dvec3 at = grid.to_physical(conformity.first);
      rep.nonconforming_at = {at.x, at.y, at.z};
      for (const auto& t : I.triangles)  // -Y: the interface triangles are kept as they are
        out.triangles.push_back({renumber[t[0]], renumber[t[1]], renumber[t[2]]});
      out.triangle_pair = result.surfaces.triangle_pair;
      std::vector<TetStats> per_material = tet_stats_by_group(V.points, V.tets, material_of, labels.size());
      for (TetStats& s : per_material) s.worst_centroid = grid.to_physical(s.worst_centroid);  // the output's units
      rep.volume = combined(per_material);
      for (size_t m = 0; m < labels.size(); ++m) rep.materials[m].tets = per_material[m];
      rep.steps.push_back({"volume mesh", "output and statistics",
                           std::chrono::duration<double>(clock::now() - output_start).count()});
    } catch (const std::exception& e) {
      rep.volume_error = e.what();
    }
    char d[160];
    if (rep.volume_error.empty())
      std::snprintf(d, sizeof d, "%s tets, dihedral angles %.1f..%.1f deg%s", count(rep.volume.tets).c_str(),
                    rep.volume.min_dihedral_deg, rep.volume.max_dihedral_deg,
                    rep.volume_one_run_because.empty() ? "" : "; one run for all materials (one failed alone)");
    else
      std::snprintf(d, sizeof d, "failed");
    stage_done(d);
  }
  return result;
}

std::vector<std::string> guarantee_failures(const MeshReport& rep) {
  std::vector<std::string> out;
  auto pair_text = [](const std::array<uint16_t, 2>& l) { return std::to_string(l[0]) + "/" + std::to_string(l[1]); };
  std::string where;
  for (const auto& left : rep.refinement_left) {
    char text[96];
    std::snprintf(text, sizeof text, "%s%s at (%.4g, %.4g, %.4g)", where.empty() ? "" : "; ", pair_text(left.labels).c_str(),
                  left.at[0], left.at[1], left.at[2]);
    where += text;
  }
  if (rep.wrong_faces > 0) out.push_back(std::to_string(rep.wrong_faces) + " wrong faces left after refinement");
  std::string bad;
  size_t bad_count = 0;
  for (const auto& ir : rep.interfaces)
    if (!ir.check.manifold()) bad += (bad_count++ < 12 ? (bad.empty() ? "" : ", ") + pair_text(ir.labels) : std::string());
  if (bad_count > 0)
    out.push_back(std::to_string(bad_count) + " of " + std::to_string(rep.interfaces.size()) +
                  " interfaces not manifold or open off the triple curves: " + bad + (bad_count > 12 ? ", ..." : ""));
  for (const auto& mr : rep.materials)
    if (mr.odd_edges > 0) out.push_back("material " + std::to_string(mr.label) + " not closed (" + std::to_string(mr.odd_edges) + " open edges)");
  if (rep.crossing_triangles > 0) out.push_back(std::to_string(rep.crossing_triangles) + " pairs of crossing interface triangles");
  if (rep.nonconforming_faces > 0) {
    char text[160];
    std::snprintf(text, sizeof text, "%zu tet faces or interface triangles where the tets' materials and the interfaces "
                  "disagree, the first at (%.4g, %.4g, %.4g)", rep.nonconforming_faces, rep.nonconforming_at[0],
                  rep.nonconforming_at[1], rep.nonconforming_at[2]);
    out.push_back(text);
  }
  if (!out.empty() && !where.empty()) out.push_back("faces the refinement could not mend: " + where);
  return out;
}

}  // namespace cpmesh::mesh
