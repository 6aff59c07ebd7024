#include "mesh/volume_mesh.h"

#include <algorithm>
#include <chrono>
#include <numeric>
#include <stdexcept>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mesh/child_process.h"

namespace cpmesh::mesh {

namespace {

struct Job {
  uint16_t material = 0;
  std::vector<std::array<uint32_t, 3>> triangles;
  std::vector<Region> regions;
  std::vector<glm::dvec3> holes;
};

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
  r.improvement = improve_tets(V.points, V.tets, points.size(), options.min_dihedral, options.max_radius_edge);
  // What moving vertices left: slivers among kept surface vertices. Refill them around a new vertex, then let the
  // vertex pass place the new vertices among their neighbours.
  r.sliver_split = split_slivers(V.points, V.tets, V.region, job.triangles, options.min_dihedral, options.max_radius_edge);
  if (r.sliver_split.inserted + r.sliver_split.flips > 0) {
    const auto again = improve_tets(V.points, V.tets, points.size(), options.min_dihedral, options.max_radius_edge);
    r.improvement.min_dihedral_after = again.min_dihedral_after;
    r.improvement.moves += again.moves;
  }
  r.runs = {{job.material, std::chrono::duration<double>(t1 - t0).count(),
             std::chrono::duration<double>(clock::now() - t1).count(), V.tets.size(), V.points.size() - points.size()}};
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

  // Largest boundary first, so that the last run to start is a small one.
  std::vector<size_t> order(jobs.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return jobs[a].triangles.size() > jobs[b].triangles.size(); });
  std::vector<MaterialMeshes> parts(jobs.size());
  std::string one_run_because;
  std::vector<std::string> errors(jobs.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, order.size(), 1), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t k = range.begin(); k != range.end(); ++k) {
      const Job& job = jobs[order[k]];
      const std::string what = "volume mesh of material " + std::to_string(labels[job.material]);
      try {
        parts[order[k]] = run_job(points, job, options, what);
      } catch (const std::exception& e) {
        const std::string message = e.what();
        errors[order[k]] = message.rfind(what, 0) == 0 ? message : what + ": " + message;
      }
    }
  }, tbb::simple_partitioner());
  std::string failed;
  for (const auto& e : errors)
    if (!e.empty()) failed += (failed.empty() ? "" : "; ") + e;
  if (!failed.empty()) {
    // A material whose boundary is not closed (a thin layer's interface with a hole) leaks into the outside when
    // meshed alone, and TetGen drops its vertices; with every interface present the leak only reaches a neighbour's
    // region. So a failed material sends the whole mesh to one run over all interfaces, as one job.
    Job all{UINT16_MAX, triangles, seeds, {}};
    MaterialMeshes r;
    try {
      r = run_job(points, all, options, "volume mesh of all materials in one run");
    } catch (const std::exception& e) {
      throw std::runtime_error(failed + "; then " + e.what());
    }
    parts.assign(1, std::move(r));
    one_run_because = failed;
  }
  // Merge in material order: each run's added points after the ones before it.
  MaterialMeshes out;
  out.one_run_because = one_run_because;
  Tets& T = out.tets;
  T.points = points;
  bool first = true;
  for (const MaterialMeshes& r : parts) {
    const auto n = uint32_t(points.size()), base = uint32_t(T.points.size());
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
    out.improvement.moves += r.improvement.moves;
    out.sliver_split.flips += r.sliver_split.flips;
    out.sliver_split.inserted += r.sliver_split.inserted;
    out.sliver_split.failed += r.sliver_split.failed;
    first = false;
  }
  return out;
}

}  // namespace cpmesh::mesh
