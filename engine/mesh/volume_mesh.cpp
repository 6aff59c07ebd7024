#include "mesh/volume_mesh.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <numeric>
#include <unordered_map>
#include <stdexcept>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include "mesh/child_process.h"
#include "mesh/elements_around.h"
#include "mesh/face_key.h"
#include "mesh/quality.h"
#include "mesh/remesh_slivers.h"
#include "mesh/split_material.h"

namespace cpmesh::mesh {

namespace {

struct Job {
  uint16_t material = 0;
  std::vector<std::array<uint32_t, 3>> triangles;
  std::vector<Region> regions;
  std::vector<glm::dvec3> holes;
  // A piece of a split material (split_material.h): its number of how many, and the volume its tets must fill.
  uint16_t piece = 0, pieces = 1;
  double volume = 0;
};

// The sliver passes over tets V: move the free vertices (index >= fixed), then refill the slivers among kept vertices
// around a new vertex (never across a face in `kept`), then move again to place the new vertices (smooth.h); then,
// where `remesh` and slivers are left, mesh the cavities around them afresh (remesh_slivers.h) and move once more.
// split.failed is then the number of tets left below the dihedral bound.
void sliver_passes(Tets& V, size_t fixed, const std::vector<std::array<uint32_t, 3>>& kept, const QualityOptions& options,
                   bool remesh, TetImproveReport& improvement, SliverSplitReport& split) {
  auto move_again = [&] {
    const auto again = improve_tets(V.points, V.tets, fixed, options.min_dihedral, options.max_radius_edge);
    improvement.min_dihedral_after = again.min_dihedral_after;
    improvement.moves += again.moves;
  };
  improvement = improve_tets(V.points, V.tets, fixed, options.min_dihedral, options.max_radius_edge);
  split = split_slivers(V.points, V.tets, V.region, kept, options.min_dihedral, options.max_radius_edge);
  if (split.inserted + split.flips > 0) move_again();
  if (remesh && improvement.min_dihedral_after < options.min_dihedral) {
    split.remeshed = remesh_slivers(V.points, V.tets, V.region, kept, fixed, options).remeshed;
    if (split.remeshed > 0) move_again();
  }
  split.failed = count_below_dihedral(V.points, V.tets, options.min_dihedral);
}

// The sliver passes' counts of a run, or of the seams, added to the totals (the angles and the slivers left are
// not sums: the callers set them).
void add_pass_counts(MaterialMeshes& out, const TetImproveReport& improvement, const SliverSplitReport& split) {
  out.improvement.moves += improvement.moves;
  out.sliver_split.flips += split.flips;
  out.sliver_split.inserted += split.inserted;
  out.sliver_split.remeshed += split.remeshed;
}

}  // namespace

void drop_pockets(Tets& V, const std::vector<std::array<uint32_t, 3>>& boundary, size_t fixed) {
  if (V.region.size() != V.tets.size()) throw std::runtime_error("drop_pockets: TetGen gave no region attributes");
  std::unordered_map<FaceKey, uint32_t, FaceKeyHash> triangle_of;
  triangle_of.reserve(boundary.size() * 2);
  for (uint32_t i = 0; i < boundary.size(); ++i) triangle_of.emplace(FaceKey(boundary[i]), i);
  std::map<int, long> inside;  // per region: faces with the region inside minus faces with it outside
  for (size_t t = 0; t < V.tets.size(); ++t)
    for (int c = 0; c < 4; ++c) {
      const auto it = triangle_of.find(FaceKey(face_opposite(V.tets[t], c)));
      if (it == triangle_of.end()) continue;
      const auto& f = boundary[it->second];
      const glm::dvec3 n = glm::cross(V.points[f[1]] - V.points[f[0]], V.points[f[2]] - V.points[f[0]]);
      inside[V.region[t]] += glm::dot(n, V.points[V.tets[t][size_t(c)]] - V.points[f[0]]) < 0 ? 1 : -1;
    }
  const size_t before = V.tets.size();
  if (keep_tets(V.tets, V.region, [&](size_t t) { return inside[V.region[t]] > 0; }) < before)
    remove_unused_points(V.points, V.tets, fixed);
}

namespace {

// One material: TetGen in a child process (a failing TetGen can kill its process; only the points it added come
// back), then the sliver passes of smooth.h here, where they may use the thread pool (a forked child of a
// multithreaded process must not).
MaterialMeshes run_job(const std::vector<glm::dvec3>& points, const Job& job, const QualityOptions& options,
                       const std::string& what) {
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  const std::string bytes = run_in_child(what, [&] {
    Tets V = constrained_quality_in_this_process(points, job.triangles, {}, job.regions, options, job.holes);
    V.points.erase(V.points.begin(), V.points.begin() + std::ptrdiff_t(points.size()));
    V.faces.clear();  // the interface triangles, unchanged (-Y)
    V.face_marker.clear();
    ByteWriter w;
    put_tets(w, V);
    return w.take();
  });
  MaterialMeshes r;
  Tets& V = r.tets;
  ByteReader in(bytes);
  if (!get_tets(in, V) || !in.done()) throw std::runtime_error(what + ": truncated result from the child process");
  const auto t1 = clock::now();
  // TetGen keeps the input points first and unmoved (-Y: none on the interface triangles); the rest are free.
  V.points.insert(V.points.begin(), points.begin(), points.end());
  if (job.pieces > 1) {
    // A piece has no region seed (a component cut by a plane has none on one side), so TetGen numbers each region its
    // faces enclose. The material's regions lie inside the piece's boundary triangles (oriented out of it); a region
    // outside them is a pocket the piece's boundary closes off without a hole seed (near a gap, where the separator
    // followed a cluster of doubtful tets: split_material.h), and its tets go. The rest must fill the volume the
    // boundary encloses.
    drop_pockets(V, job.triangles, points.size());
    V.region.assign(V.tets.size(), int(job.material) + 1);
    double volume = 0;
    for (const auto& t : V.tets) volume += tet_volume(V.points[t[0]], V.points[t[1]], V.points[t[2]], V.points[t[3]]);
    if (!(std::fabs(volume - job.volume) <= 1e-9 * std::fabs(job.volume) + 1e-12))
      throw std::runtime_error(what + ": its tets fill " + std::to_string(volume) + " of the " +
                               std::to_string(job.volume) + " its boundary encloses");
  }
  // A piece keeps its separators: the cavities along them are meshed afresh after the merge, with the separators free.
  sliver_passes(V, points.size(), job.triangles, options, job.pieces == 1, r.improvement, r.sliver_split);
  r.runs = {{job.material, std::chrono::duration<double>(t1 - t0).count(),
             std::chrono::duration<double>(clock::now() - t1).count(), V.tets.size(), V.points.size() - points.size(),
             job.piece, job.pieces}};
  V.points.erase(V.points.begin(), V.points.begin() + std::ptrdiff_t(points.size()));
  return r;
}

}  // namespace

MaterialMeshes mesh_materials(const std::vector<glm::dvec3>& points, const std::vector<std::array<uint32_t, 3>>& triangles,
                              const std::vector<std::array<uint16_t, 2>>& pair, const std::vector<Region>& seeds,
                              const std::vector<uint16_t>& labels, const QualityOptions& options) {
  check_quality_options(options);
  if (pair.size() != triangles.size()) throw std::invalid_argument("mesh_materials: one material pair per triangle");
  // A job per material with a seed; a material without one (the unbounded outside) has no tets.
  std::vector<uint8_t> seeded(labels.size(), 0);
  for (const Region& s : seeds) {
    if (s.attribute < 1 || size_t(s.attribute) > labels.size())
      throw std::invalid_argument("mesh_materials: seed attribute " + std::to_string(s.attribute) + " is no material");
    seeded[size_t(s.attribute - 1)] = 1;
  }
  std::vector<Job> jobs;
  std::vector<int> job_of(labels.size(), -1);
  for (size_t m = 0; m < labels.size(); ++m)
    if (seeded[m]) {
      job_of[m] = int(jobs.size());
      jobs.push_back({uint16_t(m), {}, {}, {}});
    }
  for (const Region& s : seeds)
    for (Job& job : jobs)
      (job.material == s.attribute - 1 ? job.regions.push_back(s) : job.holes.push_back(s.seed));
  for (size_t i = 0; i < triangles.size(); ++i)
    for (uint16_t m : pair[i])
      if (m < job_of.size() && job_of[m] >= 0) jobs[size_t(job_of[m])].triangles.push_back(triangles[i]);

  // Large materials are cut into pieces so that the runs fill the cores: each material gets runs in proportion to
  // its boundary, as long as the pieces keep options.min_piece_triangles on average (split_material.h: a piece may
  // keep half its share).
  using clock = std::chrono::steady_clock;
  const auto t_start = clock::now();
  auto seconds_since = [](clock::time_point t) { return std::chrono::duration<double>(clock::now() - t).count(); };
  const size_t runs = options.runs > 0 ? options.runs : tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
  size_t boundary_total = 0;
  for (const Job& job : jobs) boundary_total += job.triangles.size();
  std::vector<MaterialSplit> splits(jobs.size());
  std::vector<std::pair<size_t, int>> to_split;  // (job, pieces)
  for (size_t j = 0; j < jobs.size() && runs > jobs.size(); ++j) {
    const size_t n = jobs[j].triangles.size();
    const double share = double(runs) * double(n) / double(std::max<size_t>(boundary_total, 1));
    const size_t k = std::min({size_t(share + 0.5), n / std::max<size_t>(options.min_piece_triangles, 1), size_t(1024)});
    if (k >= 2) to_split.push_back({j, int(k)});
  }
  std::vector<std::string> unsplit(jobs.size());
  tbb::parallel_for(size_t(0), to_split.size(), [&](size_t i) {
    const auto [j, k] = to_split[i];
    const uint16_t m = jobs[j].material;
    std::vector<std::array<uint32_t, 3>> outward;  // the boundary with normals out of the material
    for (size_t t = 0; t < triangles.size(); ++t)
      if (pair[t][0] == m) outward.push_back(triangles[t]);
      else if (pair[t][1] == m) outward.push_back({triangles[t][0], triangles[t][2], triangles[t][1]});
    try {
      splits[j] = split_material(points, outward, k, uint32_t(points.size()));
    } catch (const std::exception& e) {
      splits[j] = {};
      splits[j].refused = e.what();
    }
    if (!splits[j].refused.empty())
      unsplit[j] = "material " + std::to_string(labels[m]) + " meshed whole: " + splits[j].refused;
  });
  // All points: the caller's, then each split's separator points (renumbered after the splits before it).
  std::vector<glm::dvec3> all_points = points;
  std::vector<Job> runs_of;  // the TetGen runs: whole materials and pieces
  std::vector<size_t> job_of_run;
  for (size_t j = 0; j < jobs.size(); ++j) {
    MaterialSplit& split = splits[j];
    if (split.pieces.empty() || !split.refused.empty()) {
      runs_of.push_back(jobs[j]);
      job_of_run.push_back(j);
      continue;
    }
    const auto shift = uint32_t(all_points.size() - points.size());
    all_points.insert(all_points.end(), split.points.begin(), split.points.end());
    for (size_t p = 0; p < split.pieces.size(); ++p) {
      Job piece{jobs[j].material, std::move(split.pieces[p]), {}, jobs[j].holes, uint16_t(p),
                uint16_t(split.pieces.size()), split.volumes[p]};
      for (auto& t : piece.triangles)
        for (auto& v : t) v = v < points.size() ? v : v + shift;
      // The material's own seeds are holes for nothing here; other materials' seeds carve their cavities.
      runs_of.push_back(std::move(piece));
      job_of_run.push_back(j);
    }
  }

  const double cut_seconds = seconds_since(t_start);
  const auto t_runs = clock::now();
  std::vector<MaterialMeshes> parts(runs_of.size());
  std::vector<std::string> errors(runs_of.size());
  auto run_all = [&](const std::vector<size_t>& which) {
    // Largest boundary first, so that the last run to start is a small one.
    std::vector<size_t> order = which;
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return runs_of[a].triangles.size() > runs_of[b].triangles.size(); });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, order.size(), 1), [&](const tbb::blocked_range<size_t>& range) {
      for (size_t k = range.begin(); k != range.end(); ++k) {
        const Job& job = runs_of[order[k]];
        std::string what = "volume mesh of material " + std::to_string(labels[job.material]);
        if (job.pieces > 1) what += ", piece " + std::to_string(job.piece + 1) + " of " + std::to_string(job.pieces);
        try {
          parts[order[k]] = run_job(all_points, job, options, what);
          errors[order[k]].clear();
        } catch (const std::exception& e) {
          const std::string message = e.what();
          errors[order[k]] = message.rfind(what, 0) == 0 ? message : what + ": " + message;
        }
      }
    }, tbb::simple_partitioner());
  };
  std::vector<size_t> everything(runs_of.size());
  std::iota(everything.begin(), everything.end(), size_t(0));
  run_all(everything);
  // A material with a failed piece is meshed whole instead: its pieces' runs are dropped, one run takes their place.
  std::vector<uint8_t> drop(runs_of.size(), 0);
  std::vector<size_t> again;
  for (size_t r = 0; r < runs_of.size(); ++r) {
    if (errors[r].empty() || runs_of[r].pieces == 1) continue;
    const size_t j = job_of_run[r];
    if (!unsplit[j].empty()) continue;
    unsplit[j] = "material " + std::to_string(labels[jobs[j].material]) + " meshed whole: " + errors[r];
    for (size_t q = 0; q < runs_of.size(); ++q)
      if (job_of_run[q] == j) drop[q] = 1;
    again.push_back(runs_of.size());
    runs_of.push_back(jobs[j]);
    job_of_run.push_back(j);
  }
  parts.resize(runs_of.size());
  errors.resize(runs_of.size());
  drop.resize(runs_of.size(), 0);
  run_all(again);
  // Runs in material order (pieces in their order); a dropped piece is left out.
  std::vector<size_t> kept;
  for (size_t r = 0; r < runs_of.size(); ++r)
    if (!drop[r]) kept.push_back(r);
  std::stable_sort(kept.begin(), kept.end(), [&](size_t a, size_t b) { return job_of_run[a] < job_of_run[b]; });
  std::string one_run_because;
  std::string failed;
  for (size_t r : kept)
    if (!errors[r].empty()) failed += (failed.empty() ? "" : "; ") + errors[r];
  std::vector<MaterialMeshes> merged;
  if (!failed.empty()) {
    // A material whose boundary is not closed (a thin layer's interface with a hole) leaks into the outside when
    // meshed alone, and TetGen drops its vertices; with every interface present the leak only reaches a neighbour's
    // region. So a failed material sends the whole mesh to one run over all interfaces, as one job.
    Job all{UINT16_MAX, triangles, seeds, {}};
    try {
      merged.push_back(run_job(points, all, options, "volume mesh of all materials in one run"));
    } catch (const std::exception& e) {
      throw std::runtime_error(failed + "; then " + e.what());
    }
    all_points = points;
    one_run_because = failed;
  } else {
    for (size_t r : kept) merged.push_back(std::move(parts[r]));
  }
  // Merge: each run's added points after the ones before it.
  MaterialMeshes out;
  out.cut_seconds = cut_seconds;
  out.runs_seconds = seconds_since(t_runs);
  const auto t_seams = clock::now();
  out.one_run_because = one_run_because;
  for (const auto& u : unsplit)
    if (!u.empty()) out.unsplit_because.push_back(u);
  bool any_piece = false;
  for (const MaterialMeshes& r : merged)
    for (const auto& run : r.runs) any_piece = any_piece || run.pieces > 1;
  for (size_t j = 0; j < jobs.size(); ++j)  // the separators of the materials meshed in pieces (others' are unused)
    if (unsplit[j].empty() && failed.empty()) out.separator_points += splits[j].points.size();
  Tets& T = out.tets;
  T.points = all_points;
  bool first = true;
  for (const MaterialMeshes& r : merged) {
    const auto n = uint32_t(all_points.size()), base = uint32_t(T.points.size());
    T.points.insert(T.points.end(), r.tets.points.begin(), r.tets.points.end());
    for (auto tet : r.tets.tets) {
      for (auto& v : tet) v = v < n ? v : base + (v - n);
      T.tets.push_back(tet);
    }
    T.region.insert(T.region.end(), r.tets.region.begin(), r.tets.region.end());
    out.runs.insert(out.runs.end(), r.runs.begin(), r.runs.end());
    if (r.tets.region.size() != r.tets.tets.size()) T.region.resize(T.tets.size(), 0);
    out.improvement.min_dihedral_before = first ? r.improvement.min_dihedral_before
                                                : std::min(out.improvement.min_dihedral_before, r.improvement.min_dihedral_before);
    out.improvement.min_dihedral_after = first ? r.improvement.min_dihedral_after
                                               : std::min(out.improvement.min_dihedral_after, r.improvement.min_dihedral_after);
    add_pass_counts(out, r.improvement, r.sliver_split);
    out.sliver_split.failed += r.sliver_split.failed;
    first = false;
  }
  if (any_piece) {
    // The pieces kept their separators as they were; now that the pieces are one mesh, the sliver passes may move
    // the separators' points and flip or refill across them (only the interface triangles are kept). The slivers
    // left are this pass's (`failed` is not summed with the runs': those the seams freed may be mended here).
    TetImproveReport seam;
    SliverSplitReport refill;
    sliver_passes(T, points.size(), triangles, options, true, seam, refill);
    add_pass_counts(out, seam, refill);
    out.improvement.min_dihedral_after = seam.min_dihedral_after;
    out.sliver_split.failed = refill.failed;
  }
  out.seam_seconds = seconds_since(t_seams);
  return out;
}

}  // namespace cpmesh::mesh
