#include "mesh/volume_mesh.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <map>
#include <stdexcept>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include "host/host_array.h"
#include "mesh/child_process.h"
#include "mesh/elements_around.h"
#include "mesh/interior_points.h"
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
  double work = 0;  // estimated tets (estimated_tets): the runs start largest first
};

double perimeter(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  return glm::length(a - b) + glm::length(b - c) + glm::length(c - a);
}

// estimated_tets of a closed boundary of `triangles` triangles, their perimeters summing to `perimeters`, enclosing
// `volume` (a closed triangle mesh of genus 0 has half as many vertices as triangles); 0 for no triangle.
double boundary_work(size_t triangles, double perimeters, double volume) {
  if (triangles == 0) return 0;
  return estimated_tets(double(triangles) / 2, std::max(0.0, volume), perimeters / double(3 * triangles));
}

// How far over the largest run by the shares (share_runs) a piece may grow where a plane moves off grazing boundary
// (split_material's `largest`). head:160 at --max-size 0.5 in 16 runs (one run each, so the sliver counts are a
// sample): largest piece 1.37 times the mean tets and 24 tets under 12 degrees with the old free moves; 1.21 and 29
// at 1.1; 1.16 and 22-32 at 1.05 (before and after the window's end was mended).
constexpr double kRunSlack = 1.05;
// And never more than this many of its own material's shares: the room the planes' old free moves gave (a quarter of
// a share either way at both ends), which also bounds each plane's search (a material far below the largest run
// would otherwise scan nearly all its vertices for every plane).
constexpr double kMostShares = 1.5;

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

// The part: the tets under the bound and kSeamRings rings around them (volume_mesh.h).
constexpr int kSeamRings = 3;

bool seam_passes(Tets& T, size_t fixed, const std::vector<std::array<uint32_t, 3>>& kept,
                 const QualityOptions& options, TetImproveReport& improvement, SliverSplitReport& split) {
  if (T.region.size() != T.tets.size()) throw std::invalid_argument("seam_passes: one region per tet");
  const size_t n_tets = T.tets.size(), n_points = T.points.size();
  const double bound = options.min_dihedral * M_PI / 180;
  HostArray<uint8_t> part(n_tets);  // in the part
  // Each tet's smallest dihedral angle, once: the tets left outside the part keep theirs (their points stay).
  HostArray<double> smallest(n_tets);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n_tets, size_t(1) << 14), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t) {
      const double angle = min_dihedral(T.points, T.tets[t]);
      part[t] = angle < bound;
      smallest[t] = angle;
    }
  });
  if (std::find(part.begin(), part.end(), uint8_t(1)) == part.end()) return false;
  // Marks the vertices of the tets where `of` holds.
  auto mark_vertices = [&](auto&& of) {
    HostArray<uint8_t> mark = filled(n_points, uint8_t(0));
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n_tets, size_t(1) << 14), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t t = r.begin(); t != r.end(); ++t)
        if (of(t))
          for (uint32_t v : T.tets[t]) std::atomic_ref<uint8_t>(mark[v]).store(1, std::memory_order_relaxed);
    });
    return mark;
  };
  for (int ring = 0; ring < kSeamRings; ++ring) {
    const HostArray<uint8_t> near = mark_vertices([&](size_t t) { return part[t] != 0; });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n_tets, size_t(1) << 14), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t t = r.begin(); t != r.end(); ++t)
        if (!part[t]) part[t] = near[T.tets[t][0]] | near[T.tets[t][1]] | near[T.tets[t][2]] | near[T.tets[t][3]];
    });
  }
  const HostArray<uint8_t> in_part = mark_vertices([&](size_t t) { return part[t] != 0; });
  const HostArray<uint8_t> outside = mark_vertices([&](size_t t) { return part[t] == 0; });
  // The part's points: the fixed ones first (T's fixed points and those an outside tet uses), then the free ones.
  std::vector<uint32_t> local(n_points, UINT32_MAX), global;
  auto stays = [&](size_t v) { return v < fixed || outside[v]; };
  for (int free = 0; free < 2; ++free)
    for (size_t v = 0; v < n_points; ++v)
      if (in_part[v] && stays(v) == (free == 0)) {
        local[v] = uint32_t(global.size());
        global.push_back(uint32_t(v));
      }
  if (global.empty()) return false;
  size_t n_fixed = 0;
  while (n_fixed < global.size() && stays(global[n_fixed])) ++n_fixed;
  Tets S;
  S.points.resize(global.size());
  for (size_t i = 0; i < global.size(); ++i) S.points[i] = T.points[global[i]];
  std::vector<size_t> part_tets;
  for (size_t t = 0; t < n_tets; ++t)
    if (part[t]) part_tets.push_back(t);
  S.tets.resize(part_tets.size());
  S.region.resize(part_tets.size());
  tbb::parallel_for(size_t(0), part_tets.size(), [&](size_t i) {
    const size_t t = part_tets[i];
    for (int c = 0; c < 4; ++c) S.tets[i][size_t(c)] = local[T.tets[t][size_t(c)]];
    S.region[i] = T.region[t];
  });
  // Kept: the interface triangles in the part, and every face of a part tet between points that outside tets use (a
  // superset of the faces it shares with them). Not the other faces between fixed points: a separator's face that
  // joins interface points only is one, and the passes over the whole mesh may flip or refill across it.
  std::vector<std::array<uint32_t, 3>> kept_here;
  for (const auto& f : kept)
    if (local[f[0]] != UINT32_MAX && local[f[1]] != UINT32_MAX && local[f[2]] != UINT32_MAX)
      kept_here.push_back({local[f[0]], local[f[1]], local[f[2]]});
  for (const auto& k : S.tets)
    for (int c = 0; c < 4; ++c) {
      const auto f = face_opposite(k, c);
      if (outside[global[f[0]]] && outside[global[f[1]]] && outside[global[f[2]]]) kept_here.push_back(f);
    }
  sliver_passes(S, n_fixed, kept_here, options, true, improvement, split);
  // The smallest angle after the passes is the part's or an outside tet's.
  const double outside_min = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, n_tets, size_t(1) << 14), M_PI,
      [&](const tbb::blocked_range<size_t>& r, double m) {
        for (size_t t = r.begin(); t != r.end(); ++t)
          if (!part[t]) m = std::min(m, smallest[t]);
        return m;
      },
      [](double a, double b) { return std::min(a, b); });
  improvement.min_dihedral_after = std::min(improvement.min_dihedral_after, outside_min * 180 / M_PI);
  // Back into T: the part's free points after T's (T's old free points of the part, now unused, go below), its tets
  // in place of the part's.
  const auto base = uint32_t(n_points);
  T.points.insert(T.points.end(), S.points.begin() + std::ptrdiff_t(n_fixed), S.points.end());
  size_t out = 0;
  for (size_t t = 0; t < n_tets; ++t)
    if (!part[t]) {
      T.tets[out] = T.tets[t];
      T.region[out++] = T.region[t];
    }
  T.tets.resize(out + S.tets.size());
  T.region.resize(out + S.tets.size());
  tbb::parallel_for(size_t(0), S.tets.size(), [&](size_t i) {
    auto k = S.tets[i];
    for (auto& v : k) v = v < n_fixed ? global[v] : base + (v - uint32_t(n_fixed));
    T.tets[out + i] = k;
    T.region[out + i] = S.region.size() == S.tets.size() ? S.region[i] : 0;
  });
  remove_unused_points(T.points, T.tets, fixed);
  return true;
}

void drop_pockets(Tets& V, const std::vector<std::array<uint32_t, 3>>& boundary, size_t fixed) {
  if (V.region.size() != V.tets.size()) throw std::runtime_error("drop_pockets: TetGen gave no region attributes");
  // The boundary triangles around each vertex: a tet's face is the first boundary triangle it matches (as a hash
  // map keeping the first of equal triangles would).
  const ElementsAround<3> around(V.points.size(), boundary);
  // Per region: faces with the region inside minus faces with it outside (integer sums: any order gives the same).
  using Votes = std::map<int, long>;
  const Votes inside = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, V.tets.size(), 4096), Votes(),
      [&](const tbb::blocked_range<size_t>& r, Votes votes) {
        for (size_t t = r.begin(); t != r.end(); ++t)
          for (int c = 0; c < 4; ++c) {
            const uint32_t i = find_triangle(around, boundary, face_opposite(V.tets[t], c));
            if (i == UINT32_MAX) continue;
            const auto& f = boundary[i];
            const glm::dvec3 n = triangle_normal(V.points, f);
            votes[V.region[t]] += glm::dot(n, V.points[V.tets[t][size_t(c)]] - V.points[f[0]]) < 0 ? 1 : -1;
          }
        return votes;
      },
      [](Votes a, const Votes& b) {
        for (const auto& [region, n] : b) a[region] += n;
        return a;
      });
  auto kept = [&](int region) {
    const auto it = inside.find(region);
    return it != inside.end() && it->second > 0;
  };
  const size_t before = V.tets.size();
  if (keep_tets(V.tets, V.region, [&](size_t t) { return kept(V.region[t]); }) < before)
    remove_unused_points(V.points, V.tets, fixed);
}

namespace {

// The most common value of `votes` (ties: the smallest), or `none` where it is empty.
uint16_t most_votes(const std::map<uint16_t, size_t>& votes, uint16_t none) {
  uint16_t best = none;
  size_t most = 0;
  for (const auto& [m, n] : votes)
    if (n > most) best = m, most = n;
  return best;
}

}  // namespace

std::vector<uint16_t> tet_materials(const Tets& V, const std::vector<std::array<uint32_t, 3>>& triangles,
                                    const std::vector<std::array<uint16_t, 2>>& pair, size_t materials,
                                    const std::function<uint16_t(uint32_t)>& fallback) {
  constexpr uint16_t kUnknown = UINT16_MAX;
  constexpr uint32_t kNone = UINT32_MAX;
  const bool regions = V.region.size() == V.tets.size();
  std::vector<uint16_t> m(V.tets.size(), kUnknown);
  size_t unknown = 0;
  for (size_t t = 0; t < V.tets.size(); ++t) {
    const int r = regions ? V.region[t] : 0;
    if (r >= 1 && size_t(r) <= materials)
      m[t] = uint16_t(r - 1);
    else
      ++unknown;
  }
  if (unknown == 0) return m;
  const ElementsAround<4> around(V.points.size(), V.tets);
  const ElementsAround<3> on(V.points.size(), triangles);
  std::vector<uint8_t> seen(V.tets.size(), 0);
  std::vector<uint32_t> part;
  for (uint32_t start = 0; start < V.tets.size(); ++start) {
    if (m[start] != kUnknown || seen[start]) continue;
    // The part: the unknown tets reached from `start` across faces that are no interface triangle.
    std::map<uint16_t, size_t> across, sides;
    part.assign(1, start);
    seen[start] = 1;
    for (size_t q = 0; q < part.size(); ++q) {
      const uint32_t t = part[q];
      for (int i = 0; i < 4; ++i) {
        const auto f = face_opposite(V.tets[t], i);
        if (const uint32_t k = find_triangle(on, triangles, f); k != kNone) {
          const glm::dvec3 n = triangle_normal(V.points, triangles[k]);
          const glm::dvec3 into = V.points[V.tets[t][size_t(i)]] - V.points[triangles[k][0]];
          const uint16_t side = pair[k][glm::dot(n, into) > 0 ? 1 : 0];
          if (side < materials) ++sides[side];
          continue;
        }
        const uint32_t u = tet_across(around, V.tets, t, i);
        if (u == kNone) continue;
        if (m[u] != kUnknown) {
          ++across[m[u]];
        } else if (!seen[u]) {
          seen[u] = 1;
          part.push_back(u);
        }
      }
    }
    uint16_t material = most_votes(across, most_votes(sides, kUnknown));
    if (material == kUnknown) {
      std::map<uint16_t, size_t> fields;
      for (uint32_t t : part) ++fields[fallback(t)];
      material = most_votes(fields, 0);
    }
    for (uint32_t t : part) m[t] = material;
  }
  return m;
}

namespace {

// One material: TetGen in a child process (a failing TetGen can kill its process; only the points it added come
// back), then the sliver passes of smooth.h here, where they may use the thread pool (a forked child of a
// multithreaded process must not).
MaterialMeshes run_job(const std::vector<glm::dvec3>& points, const Job& job, const QualityOptions& options,
                       const std::string& what) {
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  // Interior points here, on the thread pool, which the child must not use; isolated, so that a thread waiting for
  // them takes no other run (whole TetGen child and all) meanwhile. Not for the one run over all interfaces: their ray
  // parity does not tell one material's inside.
  std::vector<glm::dvec3> interior;
  if (options.interior_points && job.material != UINT16_MAX)
    tbb::this_task_arena::isolate([&] { interior = interior_points(points, job.triangles); });
  const std::string bytes = run_in_child(what, [&] {
    Tets V = constrained_quality_in_this_process(points, job.triangles, {}, job.regions, options, job.holes, interior);
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
             job.piece, job.pieces, interior.size()}};
  V.points.erase(V.points.begin(), V.points.begin() + std::ptrdiff_t(points.size()));
  return r;
}

}  // namespace

std::vector<double> material_work(const std::vector<glm::dvec3>& points, const std::vector<std::array<uint32_t, 3>>& triangles,
                                  const std::vector<std::array<uint16_t, 2>>& pair, size_t materials) {
  std::vector<double> volume(materials, 0.0), edges(materials, 0.0);
  std::vector<size_t> count(materials, 0);
  const glm::dvec3 apex = points.empty() ? glm::dvec3(0.0) : points[0];  // cones from a point near the surfaces
  for (size_t i = 0; i < triangles.size(); ++i) {
    const glm::dvec3 &a = points[triangles[i][0]], &b = points[triangles[i][1]], &c = points[triangles[i][2]];
    const double cone = glm::dot(a - apex, glm::cross(b - apex, c - apex)) / 6;
    const double edge_sum = perimeter(a, b, c);
    for (int side = 0; side < 2; ++side) {
      const uint16_t m = pair[i][size_t(side)];
      if (m >= materials) continue;
      volume[m] += side == 0 ? cone : -cone;  // the normal points out of pair[i][0]
      edges[m] += edge_sum;
      ++count[m];
    }
  }
  std::vector<double> work(materials, 0.0);
  for (size_t m = 0; m < materials; ++m) work[m] = boundary_work(count[m], edges[m], volume[m]);
  return work;
}

std::vector<int> share_runs(const std::vector<double>& work, const std::vector<size_t>& triangles, size_t runs,
                            size_t min_piece_triangles) {
  std::vector<int> pieces(work.size(), 1);
  const size_t least = std::max<size_t>(min_piece_triangles, 1);
  for (size_t total = work.size(); total < runs; ++total) {
    size_t pick = work.size();
    for (size_t j = 0; j < work.size(); ++j) {
      const auto k = size_t(pieces[j]);
      if (k < 1024 && triangles[j] / (k + 1) >= least &&
          (pick == work.size() || work[j] / double(k) > work[pick] / double(pieces[pick])))
        pick = j;
    }
    if (pick == work.size()) break;
    ++pieces[pick];
  }
  return pieces;
}

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

  // Large materials are cut into pieces so that the runs fill the cores (share_runs).
  using clock = std::chrono::steady_clock;
  const auto t_start = clock::now();
  auto seconds_since = [](clock::time_point t) { return std::chrono::duration<double>(clock::now() - t).count(); };
  const size_t runs = options.runs > 0 ? options.runs : tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
  const std::vector<double> work_of_material = material_work(points, triangles, pair, labels.size());
  std::vector<double> work(jobs.size());
  std::vector<size_t> boundary_size(jobs.size());
  for (size_t j = 0; j < jobs.size(); ++j) {
    work[j] = jobs[j].work = work_of_material[jobs[j].material];
    boundary_size[j] = jobs[j].triangles.size();
  }
  const std::vector<int> pieces_of = share_runs(work, boundary_size, runs, options.min_piece_triangles);  // asked for;
                                                                                    // a refused cut leaves one run
  // The largest run by the shares (the runs' time, where there are as many cores): a plane of any material may move
  // off grazing boundary as long as its pieces stay within kRunSlack of it.
  double largest_run = 0;
  for (size_t j = 0; j < jobs.size(); ++j) largest_run = std::max(largest_run, work[j] / pieces_of[j]);
  // A slot per run asked for: a material's pieces (or the whole material, in its first slot, where the cut is
  // refused), in material order. Each run gets the caller's points and, for a piece, its material's separator points
  // after them (MaterialSplit::first_new = points.size()): the materials are cut and meshed at once, so no run waits
  // for another material's cut. The merge numbers each material's separator points after the materials' before it.
  std::vector<size_t> first_run(jobs.size() + 1, 0);
  for (size_t j = 0; j < jobs.size(); ++j) first_run[j + 1] = first_run[j] + size_t(pieces_of[j]);
  std::vector<Job> runs_of(first_run.back());
  std::vector<size_t> job_of_run(runs_of.size());
  std::vector<uint8_t> active(runs_of.size(), 0);
  for (size_t j = 0; j < jobs.size(); ++j)
    for (size_t r = first_run[j]; r < first_run[j + 1]; ++r) job_of_run[r] = j;
  std::vector<MaterialSplit> splits(jobs.size());
  std::vector<std::vector<glm::dvec3>> run_points(jobs.size());  // per cut material: points, then its separator points
  std::vector<std::string> unsplit(jobs.size());
  std::vector<MaterialMeshes> parts(runs_of.size());
  std::vector<std::string> errors(runs_of.size());
  auto input_of = [&](size_t r) -> const std::vector<glm::dvec3>& {
    return runs_of[r].pieces > 1 ? run_points[job_of_run[r]] : points;
  };
  auto run_one = [&](size_t r) {
    const Job& job = runs_of[r];
    std::string what = "volume mesh of material " + std::to_string(labels[job.material]);
    if (job.pieces > 1) what += ", piece " + std::to_string(job.piece + 1) + " of " + std::to_string(job.pieces);
    try {
      parts[r] = run_job(input_of(r), job, options, what);
      errors[r].clear();
    } catch (const std::exception& e) {
      const std::string message = e.what();
      errors[r] = message.rfind(what, 0) == 0 ? message : what + ": " + message;
    }
  };
  // Largest estimated work first, so that the last run to start is a small one (where runs outnumber threads).
  auto run_all = [&](std::vector<size_t> order) {
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return runs_of[a].work > runs_of[b].work; });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, order.size(), 1), [&](const tbb::blocked_range<size_t>& range) {
      for (size_t k = range.begin(); k != range.end(); ++k) run_one(order[k]);
    }, tbb::simple_partitioner());
  };
  // A material meshed whole: one run, in its first slot.
  auto whole = [&](size_t j) {
    runs_of[first_run[j]] = jobs[j];
    active[first_run[j]] = 1;
  };
  // Cuts a material into its slots' runs: its pieces, or itself whole where the cut is refused.
  auto cut = [&](size_t j) {
    const uint16_t m = jobs[j].material;
    std::vector<std::array<uint32_t, 3>> outward;  // the boundary with normals out of the material
    for (size_t t = 0; t < triangles.size(); ++t)
      if (pair[t][0] == m) outward.push_back(triangles[t]);
      else if (pair[t][1] == m) outward.push_back({triangles[t][0], triangles[t][2], triangles[t][1]});
    MaterialSplit& split = splits[j];
    try {
      split = split_material(points, outward, pieces_of[j], uint32_t(points.size()),
                             std::min(kMostShares, kRunSlack * largest_run / (work[j] / pieces_of[j])));
    } catch (const std::exception& e) {
      split = {};
      split.refused = e.what();
    }
    if (!split.refused.empty() || split.pieces.empty()) {
      unsplit[j] = "material " + std::to_string(labels[m]) + " meshed whole: " +
                   (split.refused.empty() ? std::string("no pieces") : split.refused);
      whole(j);
      return;
    }
    run_points[j].reserve(points.size() + split.points.size());
    run_points[j] = points;
    run_points[j].insert(run_points[j].end(), split.points.begin(), split.points.end());
    for (size_t p = 0; p < split.pieces.size(); ++p) {
      // The material's own seeds are holes for nothing here; other materials' seeds carve their cavities.
      const size_t r = first_run[j] + p;
      double edges = 0;
      for (const auto& t : split.pieces[p]) edges += perimeter(run_points[j][t[0]], run_points[j][t[1]], run_points[j][t[2]]);
      const double work = boundary_work(split.pieces[p].size(), edges, split.volumes[p]);
      runs_of[r] = {jobs[j].material, std::move(split.pieces[p]), {}, jobs[j].holes, uint16_t(p),
                    uint16_t(split.pieces.size()), split.volumes[p], work};
      active[r] = 1;
    }
  };
  // The cuts first, all at once (each Delaunay on every core it gets), then every run, largest first. (Starting a
  // material's pieces as soon as its own cut was done left the largest cut few threads beside the other pieces'
  // TetGen children: on the paper-size head on 16 cores the last cut then ended at 34 s instead of 9.)
  std::vector<size_t> to_cut;
  for (size_t j = 0; j < jobs.size(); ++j) {
    if (pieces_of[j] > 1) to_cut.push_back(j);
    else whole(j);
  }
  tbb::parallel_for(tbb::blocked_range<size_t>(0, to_cut.size(), 1), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) cut(to_cut[i]);
  }, tbb::simple_partitioner());
  const double cut_seconds = seconds_since(t_start);
  {
    std::vector<size_t> everything;
    for (size_t r = 0; r < runs_of.size(); ++r)
      if (active[r]) everything.push_back(r);
    run_all(everything);
  }
  // A material with a failed piece is meshed whole instead: its pieces' runs are dropped, one run takes their place.
  std::vector<uint8_t> drop(runs_of.size(), 0);
  std::vector<size_t> again;
  const size_t first_pass = runs_of.size();  // (the reruns are appended below)
  for (size_t r = 0; r < first_pass; ++r) {
    if (!active[r] || errors[r].empty() || runs_of[r].pieces == 1) continue;
    const size_t j = job_of_run[r];
    if (!unsplit[j].empty()) continue;
    unsplit[j] = "material " + std::to_string(labels[jobs[j].material]) + " meshed whole: " + errors[r];
    for (size_t q = 0; q < first_pass; ++q)
      if (job_of_run[q] == j) drop[q] = 1;
    again.push_back(runs_of.size());
    runs_of.push_back(jobs[j]);
    job_of_run.push_back(j);
    active.push_back(1);
  }
  parts.resize(runs_of.size());
  errors.resize(runs_of.size());
  drop.resize(runs_of.size(), 0);
  run_all(again);
  // Runs in material order (pieces in their order); a dropped piece is left out.
  std::vector<size_t> kept;
  for (size_t r = 0; r < runs_of.size(); ++r)
    if (active[r] && !drop[r]) kept.push_back(r);
  std::stable_sort(kept.begin(), kept.end(), [&](size_t a, size_t b) { return job_of_run[a] < job_of_run[b]; });
  std::string one_run_because;
  std::string failed;
  for (size_t r : kept)
    if (!errors[r].empty()) failed += (failed.empty() ? "" : "; ") + errors[r];
  // The merged points: the caller's, then the separator points of each material meshed in pieces, in material order.
  std::vector<MaterialMeshes> merged;
  std::vector<size_t> merged_job;  // per merged run: its material's job (SIZE_MAX: the one run over all materials)
  std::vector<size_t> separator_at(jobs.size(), 0);
  std::vector<glm::dvec3> all_points = points;
  if (!failed.empty()) {
    // A material whose boundary is not closed (a thin layer's interface with a hole) leaks into the outside when
    // meshed alone, and TetGen drops its vertices; with every interface present the leak only reaches a neighbour's
    // region. So a failed material sends the whole mesh to one run over all interfaces, as one job.
    Job all{UINT16_MAX, triangles, seeds, {}};
    try {
      merged.push_back(run_job(points, all, options, "volume mesh of all materials in one run"));
      merged_job.push_back(SIZE_MAX);
    } catch (const std::exception& e) {
      throw std::runtime_error(failed + "; then " + e.what());
    }
    one_run_because = failed;
  } else {
    for (size_t j = 0; j < jobs.size(); ++j)
      if (unsplit[j].empty() && !splits[j].points.empty()) {
        separator_at[j] = all_points.size();
        all_points.insert(all_points.end(), splits[j].points.begin(), splits[j].points.end());
      }
    for (size_t r : kept) {
      merged.push_back(std::move(parts[r]));
      merged_job.push_back(job_of_run[r]);
    }
  }
  MaterialMeshes out;
  out.cut_seconds = cut_seconds;
  out.runs_seconds = std::max(0.0, seconds_since(t_start) - cut_seconds);
  const auto t_seams = clock::now();
  out.one_run_because = one_run_because;
  for (const auto& u : unsplit)
    if (!u.empty()) out.unsplit_because.push_back(u);
  bool any_piece = false;
  for (const MaterialMeshes& r : merged)
    for (const auto& run : r.runs) any_piece = any_piece || run.pieces > 1;
  out.separator_points = all_points.size() - points.size();  // of the materials meshed in pieces
  // Merge: each run's added points after the ones before it. A run's input was the caller's points, and for a piece
  // its material's separator points after them.
  Tets& T = out.tets;
  std::vector<size_t> point_base(merged.size() + 1, all_points.size()), tet_base(merged.size() + 1, 0);
  for (size_t i = 0; i < merged.size(); ++i) {
    point_base[i + 1] = point_base[i] + merged[i].tets.points.size();
    tet_base[i + 1] = tet_base[i] + merged[i].tets.tets.size();
  }
  T.points = std::move(all_points);
  T.points.resize(point_base.back());
  T.tets.resize(tet_base.back());
  T.region.resize(tet_base.back());
  tbb::parallel_for(size_t(0), merged.size(), [&](size_t i) {
    const Tets& R = merged[i].tets;
    const bool piece = !merged[i].runs.empty() && merged[i].runs[0].pieces > 1;
    const size_t separators = piece ? splits[merged_job[i]].points.size() : 0;
    const auto n = uint32_t(points.size()), n_in = uint32_t(points.size() + separators);
    const auto separator_base = uint32_t(piece ? separator_at[merged_job[i]] : 0), base = uint32_t(point_base[i]);
    std::copy(R.points.begin(), R.points.end(), T.points.begin() + std::ptrdiff_t(point_base[i]));
    tbb::parallel_for(tbb::blocked_range<size_t>(0, R.tets.size(), size_t(1) << 14), [&](const tbb::blocked_range<size_t>& rr) {
      for (size_t t = rr.begin(); t != rr.end(); ++t) {
        auto tet = R.tets[t];
        for (auto& v : tet) v = v < n ? v : v < n_in ? separator_base + (v - n) : base + (v - n_in);
        T.tets[tet_base[i] + t] = tet;
        T.region[tet_base[i] + t] = R.region.size() == R.tets.size() ? R.region[t] : 0;
      }
    });
  });
  bool first = true;
  for (const MaterialMeshes& r : merged) {
    out.runs.insert(out.runs.end(), r.runs.begin(), r.runs.end());
    out.improvement.min_dihedral_before = first ? r.improvement.min_dihedral_before
                                                : std::min(out.improvement.min_dihedral_before, r.improvement.min_dihedral_before);
    out.improvement.min_dihedral_after = first ? r.improvement.min_dihedral_after
                                               : std::min(out.improvement.min_dihedral_after, r.improvement.min_dihedral_after);
    add_pass_counts(out, r.improvement, r.sliver_split);
    out.sliver_split.failed += r.sliver_split.failed;
    first = false;
  }
  merged.clear();
  if (any_piece) {
    // The pieces kept their separators as they were; now that the pieces are one mesh, the sliver passes may move
    // the separators' points and flip or refill across them (only the interface triangles are kept). The slivers
    // left are this pass's (`failed` is not summed with the runs': those the seams freed may be mended here).
    TetImproveReport seam;
    SliverSplitReport refill;
    if (seam_passes(T, points.size(), triangles, options, seam, refill)) {
      add_pass_counts(out, seam, refill);
      out.improvement.min_dihedral_after = seam.min_dihedral_after;
      out.sliver_split.failed = refill.failed;
    }
  }
  out.seam_seconds = seconds_since(t_seams);
  return out;
}

}  // namespace cpmesh::mesh
