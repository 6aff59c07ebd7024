#include "fields/sizing_field.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <atomic>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include "fields/curve_fit.h"
#include "host/host_array.h"

namespace cpmesh::fields {

namespace {

glm::dvec3 gradient(const BrickField& f, const glm::dvec3& local) {
  glm::dvec3 g;
  f.sample_cubic_local(local, &g);
  return g;
}

// Half the thickness of material m at p: the walk along the inward normal until it leaves m again. Near a
// junction the medial axis of m starts at the junction curve itself, so "distance to where f_m stops growing" would
// drive h to zero along every triple curve; half the thickness along the normal measures thin parts (a layer of
// thickness t gives t/2, the distance to its medial plane) without that. Thicker than the stored band can show:
// infinity (does not limit h). So is a part whose walk has passed the depth where a crossing would give an h
// (density x half thickness) above h_max: it is clamped to h_max either way. (The test is the sizing's own
// expression: a crossing lies beyond the last sample inside, and rounding keeps that order.)
double half_thickness(const BrickField& field, const BrickField* offset, const glm::dvec3& p, double band, double step,
                      double density, double h_max) {
  // The field without its junction offset (indicator_fields.h): the offsets bend interfaces near triple curves by a
  // fraction of a voxel, enough to turn a walk's exit against it, and that is no thin part.
  // (Both fields in one sample: they share the grid, the weights and the gather's indexing.)
  const BrickField* both[2] = {&field, offset};
  const glm::dvec3 spacing = field.grid().spacing;
  auto value = [&](const glm::dvec3& x, glm::dvec3* g) {
    double v[2];
    glm::dvec3 grad[2];
    BrickField::sample_cubic_many(both, offset ? 2 : 1, x / spacing, v, g ? grad : nullptr);
    if (g) *g = (offset ? grad[0] - grad[1] : grad[0]) / spacing;
    return offset ? v[0] - v[1] : v[0];
  };
  glm::dvec3 g;
  value(p, &g);
  const double len = glm::length(g);
  constexpr double none = 1e300;
  if (len < 1e-12) return none;
  const glm::dvec3 n = g / len;  // into the material
  // Sphere tracing: the field is a smoothed distance (it changes by at most about one per unit length; kLipschitz
  // leaves room for the interpolant's overshoot), so no exit lies within v / kLipschitz of a point of value v.
  constexpr double kLipschitz = 1.5;
  double t_prev = 0, v_prev = 0;
  for (double t = step; t <= 2.0 * band && !(density * (0.5 * t_prev) > h_max);) {
    const double v = value(p + t * n, nullptr);
    if (v >= band * 0.999) return none;  // reached the clamped interior: thicker than the band can tell
    if (v < 0) {
      // A thin part's far side faces back (its normal opposes ours); a boundary met at an angle is the next patch
      // of a junction crease, which is sampled by the junction's own particles and does not make the part thin.
      glm::dvec3 exit;
      value(p + t * n, &exit);
      const double exit_len = glm::length(exit);
      if (exit_len > 1e-12 && glm::dot(exit / exit_len, n) < -0.5)
        return 0.5 * (t_prev + (t - t_prev) * v_prev / (v_prev - v));  // the crossing, linearly between samples
      return none;
    }
    t_prev = t;
    v_prev = v;
    t += std::max(step, v / kLipschitz);
  }
  return none;
}

// The shape operator (second fundamental form) at p, with unit normal n, from how the normals turn: the least-squares
// symmetric 2x2 S in the tangent frame (t1, t2) with (n_q - n_p) . t_i = -S_ij (q - p) . t_j over the neighbours q,
// returned as a 3x3 tensor so that neighbours' forms can be averaged. A sphere's or a cylinder's normals are exactly
// linear in position, so a wide window adds no bias; a fit of heights over the tangent plane (a quadric) would
// overestimate the curvature by the r^4 term it cannot follow, 6% on a window of 0.4 R.
glm::dmat3 fitted_shape(const glm::dvec3& p, const glm::dvec3& n, const std::vector<glm::dvec3>& points,
                        const std::vector<glm::dvec3>& normals) {
  const glm::dvec3 helper = std::fabs(n.x) < 0.7 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  const glm::dvec3 t1 = glm::normalize(glm::cross(n, helper)), t2 = glm::cross(n, t1);
  // Unknowns (s11, s12, s22); each neighbour gives two equations, -dn.t1 = s11 x + s12 y and -dn.t2 = s12 x + s22 y.
  glm::dmat3 A(0.0);
  glm::dvec3 rhs(0.0);
  for (size_t i = 0; i < points.size(); ++i) {
    const glm::dvec3 d = points[i] - p, dn = normals[i] - n;
    const double x = glm::dot(d, t1), y = glm::dot(d, t2);
    const double n1 = -glm::dot(dn, t1), n2 = -glm::dot(dn, t2);
    const glm::dvec3 r1(x, y, 0), r2(0, x, y);
    A += glm::outerProduct(r1, r1) + glm::outerProduct(r2, r2);
    rhs += r1 * n1 + r2 * n2;
  }
  if (points.size() < 6 || std::fabs(glm::determinant(A)) < 1e-12) return glm::dmat3(0.0);
  const glm::dvec3 sol = glm::inverse(A) * rhs;
  return sol.x * glm::outerProduct(t1, t1) + sol.y * (glm::outerProduct(t1, t2) + glm::outerProduct(t2, t1)) +
         sol.z * glm::outerProduct(t2, t2);
}

// Largest |eigenvalue| of a shape tensor (its third eigenvalue, along the normal, is about zero).
double max_curvature(const glm::dmat3& S) {
  const double tr = S[0][0] + S[1][1] + S[2][2];
  double fro2 = 0;
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) fro2 += S[c][r] * S[c][r];
  const double disc = std::sqrt(std::max(0.0, 2.0 * fro2 - tr * tr));
  return std::max(std::fabs(0.5 * (tr + disc)), std::fabs(0.5 * (tr - disc)));
}

// The curvature is measured at the scale of the spacing it sets: first within kFitCells cells, then again within
// kFitScale times the radius of curvature that gave, between kFitCells and kMaxFitCells cells. A window much smaller
// than the spacing sees the staircase residue of the voxels (a voxelised sphere's flat caps and their rims, several
// voxels wide), not the shape the particles must follow. Only neighbours whose normals are within 60 degrees of the
// block's own take part, which also keeps a small part's far side out of a wide window.
constexpr double kFitCells = 3.0, kMaxFitCells = 8.0, kFitScale = 0.4;
constexpr int kAveragingPasses = 3;
// A triple curve's curvature: Gaussian weights of this width (cells) along it; a fit whose points stray further than
// kCurveMaxRms cells (rms) from it is not one smooth curve and sets nothing.
constexpr double kCurveSigmaCells = 2.0, kCurveMaxRms = 0.25;
// Neighbouring particles on a triple curve settle about this many h apart (measured on the wedge ball's inner-ball
// curves at 48^3-128^3: nearest neighbours 1.14-1.27 h, the mesh edges between them up to 1.45 h).
constexpr double kCurveSpacing = 1.4;

}  // namespace

SizingStats compute_sizing_field(const IndicatorFields& F, ClosestPointEmbedding& E, const SizingOptions& options) {
  const Grid& grid = F.grid;
  const double h_min = options.h_min > 0 ? options.h_min : 0.25 * grid.min_spacing();
  const double h_max = options.h_max > 0 ? options.h_max : 4.0 * grid.min_spacing();
  const int per_block = E.sub * E.sub * E.sub;
  const size_t blocks = E.block_count();

  // Which (cell, feature) each block is.
  HostArray<uint64_t> block_key(blocks);  // every block is in one slot
  tbb::parallel_for(tbb::blocked_range<size_t>(0, E.keys.size()), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t slot = r.begin(); slot < r.end(); ++slot)
      if (E.keys[slot] != ClosestPointEmbedding::kEmpty) block_key[E.blocks[slot]] = E.keys[slot];
  });

  // 1. Per interface block whose cell touches its surface: the closest point, the unit normal, and the half
  //    thicknesses of its two materials along the normal (distance to a thin part's medial surface).
  HostArray<glm::dvec3> position(blocks), normal = filled(blocks, glm::dvec3(0.0));
  HostArray<double> ridge = filled(blocks, 1e300);
  HostArray<uint8_t> is_interface = filled(blocks, uint8_t(0));
  tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t b = r.begin(); b < r.end(); ++b) {
      const uint32_t fid = uint32_t(block_key[b] & 0xffff);
      const Feature& feature = E.features[fid];
      if (feature.kind != FeatureKind::interface) continue;
      if (!E.touches_feature(size_t(block_key[b] >> 16), b)) continue;
      const glm::dvec3 p(glm::vec3(E.fine[b * size_t(per_block)]));
      is_interface[b] = 1;
      position[b] = p;
      const BrickField& fa = F.fields[feature.materials[0]];
      const BrickField& fb = F.fields[feature.materials[1]];
      const glm::dvec3 g = gradient(fa, p) - gradient(fb, p);
      if (glm::length(g) < 1e-12) continue;
      normal[b] = glm::normalize(g);
      const double step = 0.25 * grid.min_spacing();
      const bool offsets = !F.junction_offsets.empty();
      auto half = [&](const BrickField& f, int m) {
        return half_thickness(f, offsets ? &F.junction_offsets[feature.materials[m]] : nullptr, p, F.band, step,
                              options.density, h_max);
      };
      ridge[b] = std::min(half(fa, 0), half(fb, 1));
    }
  });

  // Each interface's surface points, in buckets as wide as the widest fit.
  const double cell_size = grid.min_spacing();
  std::vector<std::vector<uint32_t>> members(E.features.size());
  for (size_t b = 0; b < blocks; ++b)
    if (is_interface[b]) members[block_key[b] & 0xffff].push_back(uint32_t(b));
  std::vector<PointBuckets> buckets(E.features.size());
  tbb::parallel_for(size_t(0), E.features.size(), [&](size_t fid) {
    const auto& m = members[fid];
    if (!m.empty()) buckets[fid] = PointBuckets(m.size(), [&](size_t i) { return position[m[i]]; }, kMaxFitCells * cell_size);
  });

  // The averaging's neighbours (the interface blocks of the same interface in the 3x3x3 cells around, the block
  // itself included), found once for all 2 x kAveragingPasses passes: counted, then listed.
  std::vector<uint32_t> neighbours_from(blocks + 1, 0), neighbours;
  auto for_each_neighbour = [&](size_t b, auto&& visit) {
    const glm::ivec3 v = grid.voxel(block_key[b] >> 16);
    const uint32_t fid = uint32_t(block_key[b] & 0xffff);
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const glm::ivec3 w = v + glm::ivec3(dx, dy, dz);
          if (!grid.inside(w.x, w.y, w.z)) continue;
          const int64_t nb = E.find_block(grid.index(w.x, w.y, w.z), fid);
          if (nb >= 0 && is_interface[size_t(nb)]) visit(uint32_t(nb));
        }
  };
  tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t b = r.begin(); b < r.end(); ++b)
      if (is_interface[b]) for_each_neighbour(b, [&](uint32_t) { ++neighbours_from[b + 1]; });
  });
  for (size_t b = 0; b < blocks; ++b) neighbours_from[b + 1] += neighbours_from[b];
  neighbours.resize(neighbours_from[blocks]);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t b = r.begin(); b < r.end(); ++b) {
      uint32_t next = neighbours_from[b];
      if (is_interface[b]) for_each_neighbour(b, [&](uint32_t nb) { neighbours[next++] = nb; });
    }
  });

  // The second fundamental form at each interface block, fitted to the points of its interface within `window`
  // whose normals agree with its own (the far side of a thin part is no part of this patch), then averaged over the
  // 3x3x3 neighbouring blocks of the same interface kAveragingPasses times: the forms still carry noise, and grading
  // spreads every low outlier of h. The signed forms are averaged; averaging |k| would bias h low.
  // (Two arrays for all passes: each pass writes every interface block's entry; the others stay 0.)
  HostArray<glm::dmat3> shape = filled(blocks, glm::dmat3(0.0)), averaged = filled(blocks, glm::dmat3(0.0));
  auto fit_shapes = [&](auto&& window_of) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks), [&](const tbb::blocked_range<size_t>& r) {
      std::vector<glm::dvec3> points, normals;
      for (size_t b = r.begin(); b < r.end(); ++b) {
        if (!is_interface[b] || normal[b] == glm::dvec3(0.0)) continue;
        const auto& m = members[block_key[b] & 0xffff];
        const double window = window_of(b);
        if (window <= 0) continue;  // keeps its form from the pass before, averaged again below
        points.clear();
        normals.clear();
        buckets[block_key[b] & 0xffff].for_each_candidate(position[b], window, [&](uint32_t i) {
          const size_t q = m[i];
          if (glm::length(position[q] - position[b]) <= window && glm::dot(normal[q], normal[b]) > 0.5)
            points.push_back(position[q]), normals.push_back(normal[q]);
        });
        shape[b] = fitted_shape(position[b], normal[b], points, normals);
      }
    });
    for (int pass = 0; pass < kAveragingPasses; ++pass) {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t b = r.begin(); b < r.end(); ++b) {
          if (!is_interface[b]) continue;
          glm::dmat3 sum(0.0);
          for (uint32_t i = neighbours_from[b]; i < neighbours_from[b + 1]; ++i) sum += shape[neighbours[i]];
          averaged[b] = sum / double(neighbours_from[b + 1] - neighbours_from[b]);
        }
      });
      shape.swap(averaged);
    }
  };
  fit_shapes([&](size_t) { return kFitCells * cell_size; });
  // A block whose first form already allows twice h_max keeps it (averaged once more with the second pass's, so
  // its neighbours' refits also average in first-pass forms): its h is h_max unless the wider window read twice
  // the curvature, and the narrow windows read the voxels' staircase as more curvature, not less. (On the 128^3
  // wedge ball at --max-size 2 that is most of the surface, and the second fits were 0.7 of the sizing's 1.8 s.)
  const double h_max_curvature = options.density / (2.0 * h_max);
  HostArray<double> window(blocks);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t b = r.begin(); b < r.end(); ++b) {
      const double k = max_curvature(shape[b]);
      window[b] = k <= h_max_curvature ? 0.0  // not refitted
                                       : std::clamp(kFitScale / k, kFitCells * cell_size, kMaxFitCells * cell_size);
    }
  });
  fit_shapes([&](size_t b) { return window[b]; });
  HostArray<glm::dmat3>().swap(averaged);  // freed: the rest needs only `shape`

  // The triple curves' own curvature at each curve block whose cell touches its curve, from a local quadratic fit of
  // the curve's points (curve_fit.h). A curve can bend more tightly than either of its surfaces: a plane that cuts a
  // ball off its centre meets it in a circle smaller than the ball, and a chord of that circle strays from it by
  // length^2 / (8 radius).
  HostArray<double> curve_radius = filled(blocks, 1e300);
  std::vector<std::vector<uint32_t>> curve_members(E.features.size());
  for (size_t b = 0; b < blocks; ++b)
    if (E.features[block_key[b] & 0xffff].kind == FeatureKind::triple_curve && E.touches_feature(block_key[b] >> 16, b))
      curve_members[block_key[b] & 0xffff].push_back(uint32_t(b));
  const double sigma = kCurveSigmaCells * cell_size;
  for (const auto& m : curve_members) {
    if (m.empty()) continue;
    std::vector<glm::dvec3> points(m.size());
    for (size_t i = 0; i < m.size(); ++i) points[i] = glm::dvec3(glm::vec3(E.fine[m[i] * size_t(per_block)]));
    const std::vector<LocalCurve> fits = fit_local_curves(points, sigma);
    for (size_t i = 0; i < m.size(); ++i)
      if (fits[i].valid && fits[i].rms <= kCurveMaxRms * cell_size && fits[i].curvature > 1e-12)
        curve_radius[m[i]] = 1.0 / fits[i].curvature;
  }

  // A chord of length L strays L^2 / (8 r) from a curve of radius r: h <= sqrt(8 r chord) / kCurveSpacing keeps the
  // curve edges within `chord` of the curve. h = density * r alone lets them stray 0.06 r (0.5 voxel at r = 8 voxels,
  // where h_max starts to bound it): on the 64^3 wedge ball, a 5.7-voxel edge of a 9-voxel circle was 0.51 voxel off
  // at its midpoint with both ends within 0.21. Measured on the wedge ball (surface meshes, seed 1, with the
  // inner-ball curves' T-junction extrapolation): largest distance of a curve edge to the analytic curves 0.46 ->
  // 0.44 voxel at 48^3, 0.51 -> 0.46 at 64^3, 0.46 -> 0.44 at 128^3, for 0.5-5% more particles.
  const double chord = options.curve_chord > 0 ? options.curve_chord * grid.min_spacing() : 1e300;
  // 2. Raw h per voxel cell: the smallest over the interface blocks in it and the triple curves' curvature there.
  //    Junction features take the h of the interfaces around them through the cells they share.
  std::vector<uint64_t> cells(blocks);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t b = r.begin(); b < r.end(); ++b) cells[b] = block_key[b] >> 16;
  });
  tbb::parallel_sort(cells.begin(), cells.end());
  cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
  // Cell -> its index in `cells`, by open addressing (the grading and the fine points look up ~30 M cells on a
  // 128^3 volume; a binary search each was a third of this stage).
  std::vector<uint64_t> slot_key;
  std::vector<uint32_t> slot_value;
  constexpr uint32_t kProbes = 64;
  build_hash_table(cells, kProbes, slot_key, slot_value);
  auto cell_slot = [&](uint64_t cell) { return find_in_hash_table(slot_key, slot_value, cell, kProbes); };
  SizingStats stats;
  std::vector<double> hc(cells.size(), h_max);
  for (size_t b = 0; b < blocks; ++b) {
    if (!is_interface[b]) continue;
    const double k = max_curvature(shape[b]);
    const double radius = k > 1e-12 ? 1.0 / k : 1e300;
    const double lfs = std::min(radius, ridge[b]);
    const double h = options.density * lfs;
    if (h < h_min || h > h_max)
      ++stats.clamped;
    else if (radius <= ridge[b])
      ++stats.curvature_limited;
    else
      ++stats.thickness_limited;
    double& cell_h = hc[size_t(cell_slot(block_key[b] >> 16))];
    cell_h = std::min(cell_h, std::clamp(h, h_min, h_max));
  }
  for (size_t b = 0; b < blocks; ++b) {
    if (curve_radius[b] >= 1e300) continue;
    const double h = std::min(options.density * curve_radius[b],
                              std::sqrt(8 * curve_radius[b] * chord) / kCurveSpacing);
    double& cell_h = hc[size_t(cell_slot(block_key[b] >> 16))];
    if (h < cell_h) ++stats.curve_limited;
    cell_h = std::min(cell_h, std::clamp(h, h_min, h_max));
  }

  // 3. Grading: h(c) <= h(n) + grading * |c - n| over the 26-neighbourhood of the band's cells, by relaxation from
  //    a frontier, all of it in parallel: each frontier cell offers its h + grading * step to its neighbours (an
  //    atomic minimum), and the cells it lowered are the next frontier. The result is the least fixed point, the
  //    smallest h(s) + grading * path length over every source cell s and path of steps: what a Dijkstra from every
  //    cell gives, on any number of threads. (A Dijkstra on one thread was 4.9 of this stage's 13.1 s on the
  //    200-voxel head phantom, 2 threads: most of it on a 16-core machine.)
  //    A cell can lower a neighbour only when its h is below h_max by more than grading x the shortest step (every
  //    h is at most h_max): the rest, the flat parts' h_max cells, start outside the frontier (and enter it if
  //    lowered).
  const double lowers_below = h_max - options.grading * grid.min_spacing();
  std::vector<uint32_t> frontier;
  for (size_t c = 0; c < cells.size(); ++c)
    if (hc[c] < lowers_below) frontier.push_back(uint32_t(c));
  std::vector<std::atomic<uint8_t>> queued(cells.size());
  double step_length[27];
  for (int d = 0; d < 27; ++d)
    step_length[d] = options.grading * glm::length(glm::dvec3(d % 3 - 1, (d / 3) % 3 - 1, d / 9 - 1) * grid.spacing);
  tbb::enumerable_thread_specific<std::vector<uint32_t>> lowered;
  while (!frontier.empty()) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, frontier.size(), 256), [&](const tbb::blocked_range<size_t>& r) {
      auto& next = lowered.local();
      for (size_t k = r.begin(); k < r.end(); ++k) {
        const uint32_t c = frontier[k];
        const double h = std::atomic_ref<double>(hc[c]).load(std::memory_order_relaxed);
        const glm::ivec3 v = grid.voxel(cells[c]);
        for (int d = 0; d < 27; ++d) {
          const glm::ivec3 w = v + glm::ivec3(d % 3 - 1, (d / 3) % 3 - 1, d / 9 - 1);
          if (d == 13 || !grid.inside(w.x, w.y, w.z)) continue;
          const int64_t n = cell_slot(grid.index(w.x, w.y, w.z));
          if (n < 0) continue;
          const double candidate = h + step_length[d];
          std::atomic_ref<double> target(hc[size_t(n)]);
          double current = target.load(std::memory_order_relaxed);
          while (candidate < current && !target.compare_exchange_weak(current, candidate, std::memory_order_relaxed)) {
          }
          if (candidate < current && !queued[size_t(n)].exchange(1, std::memory_order_relaxed)) next.push_back(uint32_t(n));
        }
      }
    });
    frontier.clear();
    for (auto& next : lowered) {
      frontier.insert(frontier.end(), next.begin(), next.end());
      next.clear();
    }
    for (uint32_t c : frontier) queued[c].store(0, std::memory_order_relaxed);
  }

  // 4. Every fine point: the graded cell field at its closest point (trilinear over the band cells there), so h is
  //    constant along the normals like the closest points themselves, and a lookup anywhere in the band reads the
  //    surface's h.
  struct Range {
    double lo = 1e300, hi = 0, sum = 0;
  };
  // (A deterministic reduce in fixed chunks: the same mean on every run and thread count.)
  const Range range = tbb::parallel_deterministic_reduce(
      tbb::blocked_range<size_t>(0, E.fine.size(), size_t(1) << 13), Range{},
      [&](const tbb::blocked_range<size_t>& r, Range acc) {
        // The 8 cells around the previous point (a block's closest points mostly share them): their slots, or -1.
        glm::ivec3 last(INT_MIN);
        int64_t slots[8];
        for (size_t i = r.begin(); i < r.end(); ++i) {
          const glm::dvec3 u = glm::dvec3(glm::vec3(E.fine[i])) / grid.spacing;
          const glm::ivec3 v(glm::floor(u));
          const glm::dvec3 t = u - glm::dvec3(v);
          if (v != last) {
            for (int c = 0; c < 8; ++c) {
              const glm::ivec3 w = v + glm::ivec3(c & 1, (c >> 1) & 1, c >> 2);
              slots[c] = grid.inside(w.x, w.y, w.z) ? cell_slot(grid.index(w.x, w.y, w.z)) : -1;
            }
            last = v;
          }
          double graded = 0, weight = 0;
          for (int c = 0; c < 8; ++c) {
            const glm::ivec3 o(c & 1, (c >> 1) & 1, c >> 2);
            const int64_t n = slots[c];
            if (n < 0) continue;
            const double wt = (o.x ? t.x : 1 - t.x) * (o.y ? t.y : 1 - t.y) * (o.z ? t.z : 1 - t.z);
            graded += wt * hc[size_t(n)];
            weight += wt;
          }
          const double h = weight > 1e-9 ? graded / weight : h_max;
          E.fine[i].w = float(h);
          acc.lo = std::min(acc.lo, h);
          acc.hi = std::max(acc.hi, h);
          acc.sum += h;
        }
        return acc;
      },
      [](Range a, const Range& b) {
        a.lo = std::min(a.lo, b.lo);
        a.hi = std::max(a.hi, b.hi);
        a.sum += b.sum;
        return a;
      });
  stats.h_min = range.lo;
  stats.h_max = range.hi;
  const double sum = range.sum;
  stats.h_mean = E.fine.empty() ? 0 : sum / double(E.fine.size());
  if (E.fine.empty()) stats.h_min = 0;
  return stats;
}

}  // namespace cpmesh::fields
