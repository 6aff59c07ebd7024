#include "fields/closest_point_embedding.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include <tbb/blocked_range.h>
#include <tbb/blocked_range2d.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include "fields/curve_fit.h"

namespace cpmesh::fields {

namespace {

using MaterialKey = std::array<uint16_t, 4>;
constexpr uint16_t kNone = 0xffff;

// Every voxel of the bricks in rows r (z, y of bricks; every x) with the values of the fields near it: visit(voxel,
// near, values), values[k] = fields[near[k]] at the voxel (as BrickField::at), near the brick's materials_near (every
// other field is -band there), brick by brick, each brick's storage looked up once per field. The fields share the
// grid, so their bricks (fields_brick_rows: the range to split among threads).
tbb::blocked_range2d<int> fields_brick_rows(const IndicatorFields& F) {
  const glm::ivec3 bricks = F.fields.empty() ? glm::ivec3(0) : F.fields[0].brick_dims();
  return tbb::blocked_range2d<int>(0, bricks.z, 0, bricks.y);
}
template <class Visit>
void for_each_voxel_values(const IndicatorFields& F, const tbb::blocked_range2d<int>& r, Visit&& visit) {
  if (F.material_count() == 0) return;
  const glm::ivec3 dims = F.grid.dims, bricks = F.fields[0].brick_dims();
  constexpr int kB = BrickField::kBrick;
  std::vector<const float*> data;
  std::vector<float> constant, values;
  for (int bz = r.rows().begin(); bz < r.rows().end(); ++bz)
    for (int by = r.cols().begin(); by < r.cols().end(); ++by)
      for (int bx = 0; bx < bricks.x; ++bx) {
        const glm::ivec3 b(bx, by, bz);
        const std::span<const uint16_t> near = F.materials_near(glm::dvec3(b * kB));
        const size_t M = near.size();
        data.resize(M);
        constant.resize(M);
        values.resize(M);
        for (size_t m = 0; m < M; ++m) {
          data[m] = F.fields[near[m]].brick_values(b);
          constant[m] = F.fields[near[m]].brick_constant(b);
        }
        const glm::ivec3 lo = b * kB, hi = glm::min(lo + kB, dims);
        for (int k = lo.z; k < hi.z; ++k)
          for (int j = lo.y; j < hi.y; ++j)
            for (int i = lo.x; i < hi.x; ++i) {
              const size_t q = size_t(((k - lo.z) * kB + (j - lo.y)) * kB + (i - lo.x));
              for (size_t m = 0; m < M; ++m) values[m] = data[m] ? data[m][q] : constant[m];
              visit(glm::ivec3(i, j, k), near, values.data());
            }
      }
}

// The fields of materials m[0..count) at local x, with their gradients in index units.
void sample_feature_fields(const IndicatorFields& F, const int* m, int count, const glm::dvec3& x, double* f,
                           glm::dvec3* grad) {
  const BrickField* fields[4];
  for (int a = 0; a < count; ++a) fields[a] = &F.fields[size_t(m[a])];
  BrickField::sample_cubic_many(fields, count, x / F.grid.spacing, f, grad);
}

// Newton with the minimum-norm step on the constraints f_{m0} - f_{ma} = 0, a = 1..k (k = 1, 2 or 3).
// On success, grad_out (optional, k + 1 entries) receives the gradients at the last sample, one short step
// (under final_step voxel) from x, and value_out (optional) f_{m0} at x (from the last sample, to first order in
// that step).
// steps (optional) counts the iterations.
bool newton(const IndicatorFields& F, const int* m, int k, glm::dvec3& x, int iterations, double tol,
            glm::dvec3* grad_out, bool give_up_stagnating, double* value_out = nullptr, uint64_t* steps = nullptr) {
  const double max_step = F.grid.min_spacing();
  constexpr int kStagnationWindow = 4;
  constexpr double kStagnationRatio = 0.75;
  // voxels: a last step this short ends the run (below). One constraint (an interface) leaves a residual of about its
  // curvature times the step squared, under 1e-4 voxel after 1e-2; two or three (curves, points) can leave more where
  // their gradients are nearly parallel, so they keep 1e-3. Measured on the 128^3 wedge ball, interfaces at 1e-2
  // against 1e-3: 11% fewer field samples in the curve smoothing and the embedding, fine points 1e-4 voxel apart on
  // average, 0.06% more than 0.01 (as often nearer their fine point as farther: where two sheets are equally near).
  const double final_step = k == 1 ? 1e-2 : 1e-3;
  double residual[kStagnationWindow] = {};
  for (int it = 0; it < iterations; ++it) {
    if (steps) ++*steps;
    if (!std::isfinite(x.x + x.y + x.z)) return false;
    double f[4];
    glm::dvec3 grad[4];
    sample_feature_fields(F, m, k + 1, x, f, grad);
    glm::dvec3 J[3];
    double g[3];
    double gmax = 0;
    for (int a = 0; a < k; ++a) {
      g[a] = f[0] - f[a + 1];
      J[a] = (grad[0] - grad[a + 1]) / F.grid.spacing;
      gmax = std::max(gmax, std::fabs(g[a]));
    }
    // Stagnation (give_up_stagnating): a run that has not cut its residual by a quarter over the last four steps is
    // circling (two sheets' constraints with no common zero nearby: a curve's band across a thin layer) and would
    // spend all its iterations there; converging runs shrink the residual faster than that, clamped walks included.
    double& four_back = residual[it % kStagnationWindow];
    if (give_up_stagnating && it >= kStagnationWindow && gmax > 100.0 * tol && gmax > kStagnationRatio * four_back)
      return false;
    four_back = gmax;
    glm::dvec3 step(0.0);
    if (k == 1) {
      const double n2 = glm::dot(J[0], J[0]);
      if (n2 < 1e-20) return false;
      step = J[0] * (g[0] / n2);
    } else if (k == 2) {
      const glm::dmat2 A(glm::dot(J[0], J[0]), glm::dot(J[1], J[0]), glm::dot(J[0], J[1]), glm::dot(J[1], J[1]));
      if (std::fabs(glm::determinant(A)) < 1e-24) return false;
      const glm::dvec2 y = glm::inverse(A) * glm::dvec2(g[0], g[1]);
      step = J[0] * y.x + J[1] * y.y;
    } else {
      const glm::dmat3 JT(J[0], J[1], J[2]);  // columns are the gradients
      const glm::dmat3 Jm = glm::transpose(JT);
      if (std::fabs(glm::determinant(Jm)) < 1e-24) return false;
      step = glm::inverse(Jm) * glm::dvec3(g[0], g[1], g[2]);
    }
    const double len = glm::length(step);
    if (len > max_step) step *= max_step / len;
    x -= step;
    // Converged: the constraints held at x and the step is within tol; or the step is so short that Newton's
    // quadratic convergence leaves the stepped point close enough (final_step above), which saves the confirming
    // sample.
    if ((gmax < tol && len < tol) || len < final_step * max_step) {
      if (grad_out) std::copy(grad, grad + k + 1, grad_out);
      if (value_out) *value_out = f[0] - glm::dot(grad[0] / F.grid.spacing, step);
      return true;
    }
  }
  return false;
}

int materials_of(const Feature& f, int* m) {
  const int k = f.material_count();
  for (int a = 0; a < k; ++a) m[a] = f.materials[size_t(a)];
  return k;
}

MaterialKey set_of(std::vector<int> m) {
  std::sort(m.begin(), m.end());
  MaterialKey s = {kNone, kNone, kNone, kNone};
  for (size_t a = 0; a < m.size() && a < 4; ++a) s[a] = uint16_t(m[a]);
  return s;
}

// Number of 26-connected components of a set of dual cells.
uint32_t count_components(std::vector<glm::ivec3>& cells) {
  auto less = [](const glm::ivec3& a, const glm::ivec3& b) {
    return a.z != b.z ? a.z < b.z : (a.y != b.y ? a.y < b.y : a.x < b.x);
  };
  std::sort(cells.begin(), cells.end(), less);
  cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
  std::vector<uint8_t> seen(cells.size(), 0);
  uint32_t components = 0;
  std::vector<size_t> stack;
  for (size_t start = 0; start < cells.size(); ++start) {
    if (seen[start]) continue;
    ++components;
    seen[start] = 1;
    stack.push_back(start);
    while (!stack.empty()) {
      const glm::ivec3 c = cells[stack.back()];
      stack.pop_back();
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const auto it = std::lower_bound(cells.begin(), cells.end(), c + glm::ivec3(dx, dy, dz), less);
            if (it == cells.end() || *it != c + glm::ivec3(dx, dy, dz)) continue;
            const size_t n = size_t(it - cells.begin());
            if (!seen[n]) {
              seen[n] = 1;
              stack.push_back(n);
            }
          }
    }
  }
  return components;
}

// Calls f(set, size) for every subset of 2 to 4 of items[0..n), n <= 8: the material sets that can be a feature where
// those materials meet.
template <class T, class F>
void for_each_material_subset(const T* items, int n, F&& f) {
  std::vector<int> ms;
  for (int mask = 1; mask < (1 << n); ++mask) {
    const int bits = __builtin_popcount(unsigned(mask));
    if (bits < 2 || bits > 4) continue;
    ms.clear();
    for (int b = 0; b < n; ++b)
      if (mask & (1 << b)) ms.push_back(int(items[b]));
    f(set_of(ms), bits);
  }
}

FeatureKind kind_of(size_t count) {
  return count == 2 ? FeatureKind::interface : (count == 3 ? FeatureKind::triple_curve : FeatureKind::quadruple_point);
}

// Least-squares parabola v = c.x + c.y u + c.z u^2 through the points of `sides` (2-D, u and v their components along
// u_axis and v_axis); nothing when they do not determine one.
std::optional<glm::dvec3> fit_parabola(std::initializer_list<const std::vector<glm::dvec2>*> sides,
                                       const glm::dvec2& u_axis, const glm::dvec2& v_axis) {
  glm::dmat3 A(0.0);
  glm::dvec3 rhs(0.0);
  for (const auto* side : sides)
    for (const auto& q : *side) {
      const double u = glm::dot(q, u_axis);
      const glm::dvec3 row(1, u, u * u);
      A += glm::outerProduct(row, row);
      rhs += row * glm::dot(q, v_axis);
    }
  if (!(std::fabs(glm::determinant(A)) > 1e-9)) return std::nullopt;
  return glm::inverse(A) * rhs;
}

// The T-junction extrapolation (see the header, triple_curve_moves): the move of the curve point p of `feature`
// to where its stem interface, extended as a line, meets its through surface, interpolated as a parabola, both in
// the plane across the curve at p. 0 where the curve is no T-junction, a side has too few samples, or the move
// would exceed a voxel.
glm::dvec3 junction_extrapolation(const IndicatorFields& F, const Feature& feature, const glm::dvec3& p) {
  constexpr double kNear = 2.5, kFar = 6.0, kStep = 0.5;  // voxels: the samples' distances from p
  constexpr size_t kMinSamples = 4;
  constexpr double kMaxBend = 40.0;  // degrees: the through surface's two tangents at p at least 140 degrees apart
  const double h = F.grid.min_spacing();
  const int m[3] = {feature.materials[0], feature.materials[1], feature.materials[2]};
  double f[3];
  glm::dvec3 grad[3];
  auto sample = [&](const glm::dvec3& x) {
    sample_feature_fields(F, m, 3, x, f, grad);
    for (auto& g : grad) g /= F.grid.spacing;
  };
  sample(p);
  const glm::dvec3 t0 = glm::cross(grad[0] - grad[1], grad[0] - grad[2]);
  if (!(glm::length(t0) > 1e-12)) return glm::dvec3(0.0);
  const glm::dvec3 t = glm::normalize(t0);  // the curve's tangent
  const glm::dvec3 e1 = glm::normalize(glm::cross(t, std::fabs(t.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0)));
  const glm::dvec3 e2 = glm::cross(t, e1);
  const std::array<glm::dvec3, 3> grad_p = {grad[0], grad[1], grad[2]};
  auto across = [&](const glm::dvec3& v) { return glm::dvec2(glm::dot(v, e1), glm::dot(v, e2)); };
  // Whether a material other than the curve's three lies above `level` at x: the march has left the interface's patch
  // (near a quadruple point, where a wedge plane meets the outer sphere, it would otherwise follow the zero set of two
  // fields on into the fourth material, where their difference is the extension of their distance fields).
  auto beyond_patch = [&](const glm::dvec3& x, double level) {
    const glm::ivec3 v = glm::ivec3(glm::round(x / F.grid.spacing));
    for (uint16_t o : F.materials_near(x / F.grid.spacing)) {
      if (int(o) == m[0] || int(o) == m[1] || int(o) == m[2]) continue;
      // The interpolant stays within about a voxel of its nearest sample (as in build_embedding's intruder test).
      if (F.fields[o].at(v.x, v.y, v.z) < level - 2.0 * h) continue;
      if (F.fields[o].sample_cubic_local(x) > level) return true;
    }
    return false;
  };
  // Interface k is the one between the two materials other than k: x = pair[k][0], y = pair[k][1].
  constexpr int pair[3][2] = {{1, 2}, {0, 2}, {0, 1}};
  // Each interface's points, marching out from p: every step continues in the direction from p to the last point
  // (the directions at p itself are the rounded fields', tens of degrees off) and is projected onto the zero set
  // within the plane across the curve. The march stops where the point leaves the interface's patch.
  std::array<std::vector<glm::dvec2>, 3> points;
  std::array<glm::dvec2, 3> dir;
  for (int k = 0; k < 3; ++k) {
    const int x = pair[k][0], y = pair[k][1];
    glm::dvec2 d = across(glm::cross(t, grad_p[size_t(x)] - grad_p[size_t(y)]));
    if (!(glm::length(d) > 1e-12)) return glm::dvec3(0.0);
    d = glm::normalize(d);
    if (glm::dot(d, across(grad_p[size_t(x)] - grad_p[size_t(k)])) < 0) d = -d;  // away from material k
    for (double s = kNear; s <= kFar + 1e-9; s += kStep) {
      glm::dvec3 q = p + (s * h) * (e1 * d.x + e2 * d.y);
      bool converged = false;
      for (int it = 0; it < 12 && !converged; ++it) {
        sample(q);
        const double g = f[x] - f[y];
        glm::dvec3 gg = grad[x] - grad[y];
        gg -= glm::dot(gg, t) * t;
        const double n2 = glm::dot(gg, gg);
        if (n2 < 1e-20) break;
        glm::dvec3 step = gg * (g / n2);
        if (glm::length(step) > h) step *= h / glm::length(step);
        q -= step;
        converged = std::fabs(g) < 1e-4 * h && glm::length(step) < 1e-4 * h;
      }
      if (!converged) break;
      sample(q);
      if (f[x] < f[k] || f[y] < f[k]) break;  // beyond another curve
      if (beyond_patch(q, std::min(f[x], f[y]))) break;  // beyond a junction with a fourth material
      const glm::dvec2 v = across(q - p);
      if (glm::length(v) < 0.5 * s * h) break;  // turned back towards p
      points[size_t(k)].push_back(v / h);        // voxel units from here on
      d = glm::normalize(v);
    }
    if (points[size_t(k)].size() < kMinSamples) return glm::dvec3(0.0);
    glm::dvec2 mean(0.0);
    for (const auto& v : points[size_t(k)]) mean += v;
    dir[size_t(k)] = glm::normalize(mean);
  }
  // Each interface's tangent at p, turned from its mean direction: w = c1 u + c2 u^2 through p (u along the mean
  // direction, w across it), fitted to its points, leaves p at atan(c1) from the mean direction.
  std::array<glm::dvec2, 3> tangent;
  for (int k = 0; k < 3; ++k) {
    const glm::dvec2 u_axis = dir[size_t(k)], w_axis(-u_axis.y, u_axis.x);
    double Suu = 0, Suuu = 0, Suuuu = 0, Suw = 0, Suuw = 0;
    for (const auto& q : points[size_t(k)]) {
      const double u = glm::dot(q, u_axis), w = glm::dot(q, w_axis);
      Suu += u * u, Suuu += u * u * u, Suuuu += u * u * u * u, Suw += u * w, Suuw += u * u * w;
    }
    const double det = Suu * Suuuu - Suuu * Suuu;
    const double turn = std::fabs(det) > 1e-9 ? std::atan((Suuuu * Suw - Suuu * Suuw) / det) : 0.0;
    const double c = std::cos(turn), s = std::sin(turn);  // counter-clockwise
    tangent[size_t(k)] = glm::dvec2(c * u_axis.x - s * u_axis.y, s * u_axis.x + c * u_axis.y);
  }
  // The through surface is the pair of interfaces that continue each other across the curve: their tangents at p
  // less than 40 degrees from opposite. The tangents, not the mean directions: where a plane ends on a small ball
  // (radius 6.75 voxels on the 48^3 wedge ball) the ball's two sides' mean directions are only 128-139 degrees
  // apart, as far from opposite as at a Y-junction, where three straight interfaces meet at 120 degrees. Measured on
  // the wedge ball at 40^3-128^3, degrees from opposite: the through pair of the rim and inner-ball curves 12-20
  // (median), at most 27-42; the other pairs there 51 or more; every pair on the axis, a Y-junction, 40.1 or more
  // (40.1 at 128^3, 43-47 at 40^3-64^3). The stem is the third interface.
  int stem = -1;
  double least_bend = kMaxBend;
  for (int k = 0; k < 3; ++k) {
    const double cos_ab = glm::dot(tangent[size_t((k + 1) % 3)], tangent[size_t((k + 2) % 3)]);
    const double bend = 180.0 - glm::degrees(std::acos(std::clamp(cos_ab, -1.0, 1.0)));
    if (bend < least_bend) least_bend = bend, stem = k;
  }
  if (stem < 0) return glm::dvec3(0.0);
  const auto& side_a = points[size_t((stem + 1) % 3)];
  const auto& side_b = points[size_t((stem + 2) % 3)];
  // Through surface: v = c0 + c1 u + c2 u^2, u along (dir a - dir b), by least squares over both sides.
  const glm::dvec2 u_axis = glm::normalize(dir[size_t((stem + 1) % 3)] - dir[size_t((stem + 2) % 3)]);
  const glm::dvec2 v_axis(-u_axis.y, u_axis.x);
  const auto fit = fit_parabola({&side_a, &side_b}, u_axis, v_axis);
  if (!fit) return glm::dvec3(0.0);
  const glm::dvec3 c = *fit;
  // Stem: offset o = o0 + o1 s across its direction, by least squares.
  const glm::dvec2 sd = dir[size_t(stem)], sn(-sd.y, sd.x);
  double S = 0, Ss = 0, Sss = 0, So = 0, Sso = 0;
  for (const auto& q : points[size_t(stem)]) {
    const double s = glm::dot(q, sd), o = glm::dot(q, sn);
    S += 1, Ss += s, Sss += s * s, So += o, Sso += s * o;
  }
  const double det = S * Sss - Ss * Ss;
  if (!(std::fabs(det) > 1e-9)) return glm::dvec3(0.0);
  const double o0 = (Sss * So - Ss * Sso) / det, o1 = (S * Sso - Ss * So) / det;
  // Where the line meets the parabola: Newton on s from p's end of the line.
  auto on_stem = [&](double s) { return sd * s + sn * (o0 + o1 * s); };
  auto gap = [&](double s) {
    const glm::dvec2 q = on_stem(s);
    const double u = glm::dot(q, u_axis);
    return glm::dot(q, v_axis) - (c.x + c.y * u + c.z * u * u);
  };
  double s = 0;
  for (int it = 0; it < 20; ++it) {
    const double g = gap(s), dg = (gap(s + 1e-4) - g) / 1e-4;
    if (!(std::fabs(dg) > 1e-9)) return glm::dvec3(0.0);
    s -= std::clamp(g / dg, -1.0, 1.0);
  }
  if (!(std::fabs(gap(s)) < 1e-6)) return glm::dvec3(0.0);
  const glm::dvec2 q = on_stem(s) * h;
  const glm::dvec3 move = e1 * q.x + e2 * q.y;
  // Part of the way only: the meeting point carries the interfaces' staircase ripple (up to +-0.3 voxel a few voxels
  // out, which the stem's line extrapolates), so shrinking the estimate towards no move lowers the error. Measured on
  // the wedge ball (40^3-128^3, mesh curve edges, mean): 0.4 of the way 0.13-0.17, 0.6 0.12-0.16, 0.8 0.12-0.16,
  // the whole way 0.14-0.19 voxel; the largest errors are least at 0.6. The cap is on the move made: capping the
  // estimate at a voxel instead left some points of a curve unmoved between moved ones, and the 128^3 wedge ball's
  // whole curve edges up to 0.81 voxel off instead of 0.47.
  constexpr double kShrink = 0.6;
  const glm::dvec3 made = kShrink * move;
  return glm::length(made) <= h ? made : glm::dvec3(0.0);
}

// The curve smoothing's moves (see the header) from an embedding of the curves: owner[i] is the feature whose
// closest point fine point i stores. One move per representative: the mean stored point in a cell of a quarter voxel.
std::vector<CurveMove> curve_moves(const IndicatorFields& F, const ClosestPointEmbedding& E, std::span<const uint32_t> owner,
                                   double sigma, bool extrapolate) {
  const double h = E.grid.min_spacing();
  const double cell = 0.25 * h;
  auto key_of = [](const glm::dvec3& x, double size) { return cell_key(glm::ivec3(glm::floor(x / size))); };
  std::vector<CurveMove> out;
  for (uint32_t fid = 0; fid < E.features.size(); ++fid) {
    const Feature& feature = E.features[fid];
    if (feature.kind != FeatureKind::triple_curve) continue;
    std::unordered_map<uint64_t, uint32_t> rep_of;
    std::vector<glm::dvec3> sum;
    std::vector<uint32_t> count;
    for (size_t i = 0; i < E.fine.size(); ++i) {
      if (owner[i] != fid) continue;
      const glm::dvec3 x(glm::vec3(E.fine[i]));
      const auto [it, added] = rep_of.try_emplace(key_of(x, cell), uint32_t(sum.size()));
      if (added) sum.emplace_back(0.0), count.push_back(0);
      sum[it->second] += x;
      ++count[it->second];
    }
    if (sum.empty()) continue;
    std::vector<glm::dvec3> reps(sum.size());
    for (size_t r = 0; r < reps.size(); ++r) reps[r] = sum[r] / double(count[r]);
    // First to where the interfaces meet when extended into the junction, then along the curve.
    std::vector<glm::dvec3> extrapolated(reps.size(), glm::dvec3(0.0));
    if (extrapolate)
      tbb::parallel_for(tbb::blocked_range<size_t>(0, reps.size()), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t r = range.begin(); r < range.end(); ++r) extrapolated[r] = junction_extrapolation(F, feature, reps[r]);
      });
    std::vector<glm::dvec3> corrected(reps.size());
    for (size_t r = 0; r < reps.size(); ++r) corrected[r] = reps[r] + extrapolated[r];
    const std::vector<LocalCurve> fits = fit_local_curves(corrected, sigma);
    std::vector<glm::dvec3> quads;  // this curve's ends
    for (const auto& qp : E.quadruple_points) {
      const auto& qm = E.features[qp.feature].materials;
      if (std::all_of(feature.materials.begin(), feature.materials.begin() + 3,
                      [&](uint16_t m) { return std::find(qm.begin(), qm.end(), m) != qm.end(); }))
        quads.push_back(qp.position);
    }
    const size_t first = out.size();
    out.resize(first + reps.size());
    for (size_t r = 0; r < reps.size(); ++r) {
      // To the local quadratic fit, or no move when the neighbourhood is not one smooth curve (see the header).
      const LocalCurve& fit = fits[r];
      const bool moves = fit.valid && fit.rms <= 0.25 * h && glm::length(fit.offset) <= 0.5 * h;
      double to_quad = std::numeric_limits<double>::infinity();
      for (const auto& q : quads) to_quad = std::min(to_quad, glm::length(q - reps[r]));
      const double t = std::clamp(to_quad / (2.0 * sigma), 0.0, 1.0);
      const double fade = t * t * (3 - 2 * t);
      out[first + r] = {reps[r], moves ? (extrapolated[r] + fit.offset) * fade : glm::dvec3(0.0),
                        moves && fade > 0 && glm::length(extrapolated[r]) > 0};
    }
  }
  return out;
}

}  // namespace

uint32_t embedding_hash(uint64_t key) {
  // 64-bit to 32-bit mix (murmur3 finaliser on both halves), done in 32-bit arithmetic so GLSL matches exactly.
  uint32_t lo = uint32_t(key), hi = uint32_t(key >> 32);
  uint32_t h = lo ^ (hi * 0x9e3779b9u);
  h ^= h >> 16;
  h *= 0x85ebca6bu;
  h ^= h >> 13;
  h *= 0xc2b2ae35u;
  h ^= h >> 16;
  return h;
}

void build_hash_table(const std::vector<uint64_t>& distinct_keys, uint32_t max_probes, std::vector<uint64_t>& keys,
                      std::vector<uint32_t>& values) {
  size_t capacity = 16;
  while (capacity < 2 * distinct_keys.size()) capacity *= 2;
  while (true) {
    keys.assign(capacity, ClosestPointEmbedding::kEmpty);
    values.assign(capacity, 0);
    bool fits = true;
    for (size_t i = 0; i < distinct_keys.size() && fits; ++i) {
      size_t slot = embedding_hash(distinct_keys[i]) & (capacity - 1);
      uint32_t probe = 0;
      while (keys[slot] != ClosestPointEmbedding::kEmpty) {
        slot = (slot + 1) & (capacity - 1);
        if (++probe >= max_probes) fits = false;
      }
      keys[slot] = distinct_keys[i];
      values[slot] = uint32_t(i);
    }
    if (fits) return;
    capacity *= 2;
  }
}

int64_t find_in_hash_table(const std::vector<uint64_t>& keys, const std::vector<uint32_t>& values, uint64_t key,
                           uint32_t max_probes) {
  if (keys.empty()) return -1;
  const size_t mask = keys.size() - 1;
  size_t slot = embedding_hash(key) & mask;
  for (uint32_t probe = 0; probe < max_probes; ++probe, slot = (slot + 1) & mask) {
    if (keys[slot] == key) return values[slot];
    if (keys[slot] == ClosestPointEmbedding::kEmpty) return -1;
  }
  return -1;
}

int64_t ClosestPointEmbedding::find_block(size_t cell, uint32_t feature) const {
  return find_in_hash_table(keys, blocks, (uint64_t(cell) << 16) | feature, kMaxProbes);
}

int ClosestPointEmbedding::feature_index(FeatureKind kind, std::array<uint16_t, 4> materials) const {
  for (size_t i = 0; i < features.size(); ++i)
    if (features[i].kind == kind && features[i].materials == materials) return int(i);
  return -1;
}

namespace {

// The differences f_m0 - f_ma (a = 1..count-1) of a feature's fields at x, and their gradients (local units).
void feature_differences(const IndicatorFields& F, const int* m, int count, const glm::dvec3& x, double* v,
                         glm::dvec3* grad) {
  double f[4];
  glm::dvec3 g[4];
  sample_feature_fields(F, m, count, x, f, g);
  for (int a = 0; a + 1 < count; ++a) v[a] = f[0] - f[a + 1], grad[a] = (g[0] - g[a + 1]) / F.grid.spacing;
}

// Where the interface difference (value v0 and gradient grad0 at x0) first changes sign along a straight walk from
// x0 down the gradient (steps of a tenth of a voxel, up to kSideWalk voxels, then bisection): a start on the
// interface's nearest side. Newton from x0 itself can overshoot a sheet thinner than its step; the walk cannot
// overshoot one thicker than a tenth of a voxel. False where the walk finds no change.
constexpr double kSideWalk = 4.0;
bool start_on_nearest_side(const IndicatorFields& F, const int* m, const glm::dvec3& x0, double v0,
                           const glm::dvec3& grad0, glm::dvec3& out) {
  if (v0 == 0) return false;
  const BrickField &f0 = F.fields[size_t(m[0])], &f1 = F.fields[size_t(m[1])];
  auto same_sign = [&](const glm::dvec3& x) {
    const glm::dvec3 ijk = x / F.grid.spacing;
    return (f0.sample_cubic(ijk) - f1.sample_cubic(ijk)) * v0 > 0;
  };
  const glm::dvec3 step = glm::normalize(grad0) * (v0 > 0 ? -0.1 : 0.1) * F.grid.min_spacing();
  glm::dvec3 lo = x0;
  for (int i = 1; i <= int(kSideWalk * 10); ++i) {
    glm::dvec3 hi = x0 + step * double(i);
    if (same_sign(hi)) {
      lo = hi;
      continue;
    }
    for (int k = 0; k < 10; ++k) {
      const glm::dvec3 mid = 0.5 * (lo + hi);
      (same_sign(mid) ? lo : hi) = mid;
    }
    out = 0.5 * (lo + hi);
    return true;
  }
  return false;
}

// project_to_feature, and where the start is a neighbour's closest point on the same feature, that projection's last
// gradients (start_gradients, index units: a sample saved). On success, value_out receives the field of the
// feature's first material at `out` (from the last Newton sample: the embedding's restriction test compares the
// other fields with it) and gradients_out this projection's gradients.
// give_up_stagnating applies to every Newton run here; give_up_first to the runs before the rounds only: for a caller
// with another start to try when this one fails, which then does not need the point a failed run stopped at.
bool project_from(const IndicatorFields& F, const Feature& feature, const glm::dvec3& x0, glm::dvec3& out,
                  int newton_iterations, int rounds, const glm::dvec3* start, const glm::dvec3* start_gradients,
                  bool give_up_stagnating, bool give_up_first, double* value_out, glm::dvec3* gradients_out,
                  uint64_t* steps = nullptr) {
  int m[4];
  const int count = materials_of(feature, m);
  const int k = count - 1;
  const double tol = 1e-5 * F.grid.min_spacing();
  // The foot of x0 on the tangent space at x (on the feature), from the fields' gradients there (index units).
  auto foot = [&](const glm::dvec3& x, const glm::dvec3* grad) {
    glm::dvec3 g[4];
    for (int a = 0; a < count; ++a) g[a] = grad[a] / F.grid.spacing;
    const glm::dvec3 d = x0 - x;
    if (k == 1) {
      const glm::dvec3 n = glm::normalize(g[0] - g[1]);
      return x + d - n * glm::dot(d, n);
    }
    const glm::dvec3 t = glm::normalize(glm::cross(g[0] - g[1], g[0] - g[2]));
    return x + t * glm::dot(d, t);
  };
  glm::dvec3 g[4];
  glm::dvec3 x = x0;
  if (start) {
    // A start on the feature (a neighbour's closest point): begin at the foot of x0 on its tangent space, which is
    // within the curvature's reach of the answer, so Newton and the rounds below have little left to do.
    x = *start;
    if (k < 3) {
      if (start_gradients) {
        std::copy(start_gradients, start_gradients + count, g);
      } else {
        double f[4];
        sample_feature_fields(F, m, count, x, f, g);
      }
      const glm::dvec3 next = foot(x, g);
      if (std::isfinite(next.x + next.y + next.z)) x = next;
    }
  }
  double value = 0, next_value = 0;
  const bool give_up_early = give_up_stagnating || give_up_first;
  bool ok = newton(F, m, k, x, newton_iterations, tol, g, give_up_early, &value, steps);
  if (!ok && start) {  // the foot led Newton astray (a field's edge, another sheet): from the start itself
    x = *start;
    ok = newton(F, m, k, x, newton_iterations, tol, g, give_up_early, &value, steps);
  }
  for (int round = 1; ok && k < 3 && round < rounds; ++round) {
    // Move the start to the foot of x0 on the tangent space at x and solve again, so the result is the closest point
    // rather than the end of the gradient path; every round ends with a converged Newton solve. Newton's last
    // gradients are taken at x (within its tolerance).
    const glm::dvec3 next = foot(x, g);
    // A foot point that moves less than a thousandth of a voxel is found: the embedding's accuracy is a hundredth.
    // Parallel gradients (a curve's two interfaces tangent to each other) leave no tangent: keep x.
    if (!std::isfinite(next.x + next.y + next.z) || glm::length((next - x) / F.grid.spacing) < 1e-3) break;
    glm::dvec3 y = next;
    // A failed run keeps the last converged point (and its gradients and value).
    if (!newton(F, m, k, y, newton_iterations, tol, g, give_up_stagnating, &next_value, steps)) break;
    x = y;
    value = next_value;
  }
  out = x;
  if (ok && value_out) *value_out = value;
  if (ok && gradients_out) std::copy(g, g + count, gradients_out);
  return ok;
}

// The smallest step from x0 onto the feature's linearization at x0 (an interface: f_m0 - f_m1 = 0; a triple curve:
// f_m0 - f_m1 = f_m0 - f_m2 = 0), the differences' value and gradient at x0 in v and grad; false where the gradients
// vanish or are parallel. Near the feature the differences change by about their gradients per unit length, so the
// step's length estimates the distance to the feature's nearest sheet or curve.
bool linearized_step(const IndicatorFields& F, const int* m, int count, const glm::dvec3& x0, glm::dvec3& step,
                     double v[2], glm::dvec3 grad[2]) {
  feature_differences(F, m, count, x0, v, grad);
  if (count == 2) {
    const double gg = glm::dot(grad[0], grad[0]);
    step = -grad[0] * (v[0] / gg);
    return gg > 0;
  }
  // Two constraints: d = -J^T (J J^T)^-1 v.
  const double aa = glm::dot(grad[0], grad[0]), ab = glm::dot(grad[0], grad[1]), bb = glm::dot(grad[1], grad[1]);
  const double det = aa * bb - ab * ab;
  if (!(det > 1e-12 * aa * bb)) return false;
  const double la = (bb * v[0] - ab * v[1]) / det, lb = (aa * v[1] - ab * v[0]) / det;
  step = -(la * grad[0] + lb * grad[1]);
  return true;
}

// x0's projection cp onto an interface or a triple curve, replaced by a projection from a start near x0 where that one
// is nearer: cp, own (f of the first material there) and gradients (4 entries) then take its values. The start is, for
// an interface, the sign change on a walk down the gradient (start_on_nearest_side), tried where cp lies farther from
// x0 than the fields' linearization says the interface is (linearized_step); for a curve the linearized foot x0 +
// step, tried at every point: the linearization of two constraints a voxel out is too rough to say when (the falx-end
// test of fields_embedding_test: 52 of 1,988 points kept the other curve where it chose, none now).
// A projection warm-started from the previous fine point's closest point keeps that point's sheet or curve: where a
// one-voxel sheet (a falx, a CSF layer) lies between a block's fine points, the points on one side and inside it
// took the other side's points (the one-voxel-sheet test: 325 of 8056 fine points, a voxel off instead of a
// twentieth), and that side of the sheet got no seeds and no particles; where such a sheet ends on a layer, its two
// triple curves are one feature a voxel apart, and one of them lost its points the same way (the falx-end test).
void take_nearer_projection(const IndicatorFields& F, const Feature& feature, const glm::dvec3& x0,
                            const EmbeddingOptions& options, bool give_up_stagnating, glm::dvec3& cp, double& own,
                            glm::dvec3* gradients, uint64_t& steps) {
  int m[4];
  const int count = materials_of(feature, m);
  if (count != 2 && count != 3) return;
  glm::dvec3 step, grad[2];
  double v[2];
  if (!linearized_step(F, m, count, x0, step, v, grad) ||
      (count == 2 && glm::length(x0 - cp) <= 1.5 * glm::length(step) + 0.1 * F.grid.min_spacing()))
    return;
  glm::dvec3 start = x0 + step, nearer, g[4];
  double own_nearer = 0;
  if ((count == 2 && !start_on_nearest_side(F, m, x0, v[0], grad[0], start)) ||
      !project_from(F, feature, x0, nearer, options.newton_iterations, options.closest_point_rounds, &start, nullptr,
                    give_up_stagnating, false, &own_nearer, g, &steps) ||
      !(glm::length(nearer - x0) < glm::length(cp - x0)))
    return;
  cp = nearer, own = own_nearer;
  std::copy(g, g + 4, gradients);
}

}  // namespace

bool project_to_feature(const IndicatorFields& F, const Feature& feature, const glm::dvec3& x0, glm::dvec3& out,
                        int newton_iterations, int rounds, const glm::dvec3* start, bool give_up_stagnating) {
  return project_from(F, feature, x0, out, newton_iterations, rounds, start, nullptr, give_up_stagnating, false, nullptr,
                      nullptr);
}

double feature_distance(const IndicatorFields& F, const Feature& feature, const glm::dvec3& x) {
  int m[4];
  const int count = materials_of(feature, m);
  double f[4];
  glm::dvec3 grad[4];
  sample_feature_fields(F, m, count, x, f, grad);
  double farthest = 0;
  for (int a = 1; a < count; ++a) {
    const double slope = glm::length((grad[0] - grad[a]) / F.grid.spacing);
    if (!(slope > 0)) return std::numeric_limits<double>::infinity();
    farthest = std::max(farthest, std::fabs(f[0] - f[a]) / slope);
  }
  // Another material's field above the feature's: the point lies inside that material, at about the difference (the
  // fields are signed distances near their boundaries). This also settles points where the feature's fields are
  // clamped at the band's depth (they meet everywhere there): the material the point lies in is far above them.
  // Only the materials near x can be above -band, the floor of the feature's fields too (IndicatorFields::near_list).
  const double lowest = *std::min_element(f, f + count);
  std::vector<const BrickField*> others;
  for (uint16_t c : F.materials_near(x / F.grid.spacing))
    if (std::find(m, m + count, int(c)) == m + count) others.push_back(&F.fields[c]);
  std::vector<double> value(others.size());
  if (!others.empty()) BrickField::sample_cubic_many(others.data(), int(others.size()), x / F.grid.spacing, value.data(), nullptr);
  for (double v : value) farthest = std::max(farthest, v - lowest);
  return farthest;
}

namespace {

// Voxels from a feature within which every voxel's block must exist: the lookup band plus a WENO4 stencil's reach
// (2 fine steps beyond the query per axis, and a cell's fine points lie up to sub - 1 fine steps from its corner; both
// along a diagonal at worst). The indicator fields must be stored deeper than this (build_embedding, step 3).
double stencil_reach(const EmbeddingOptions& options, int sub) {
  return options.band + std::sqrt(3.0) * double(sub + 1) / sub;
}
constexpr double kReachShareOfBand = 0.95;

}  // namespace

int embedding_subcells(const EmbeddingOptions& options, double size_floor_voxels, double thin_share,
                       double band_voxels) {
  if (options.sub > 0) return options.sub;
  const bool band_allows = band_voxels <= 0 || stencil_reach(options, 1) < kReachShareOfBand * band_voxels;
  // (The floor with a little room: a spacing read from a file and the same number typed for --min-size may differ in
  // the last digits.)
  return size_floor_voxels >= 1.0 - 1e-6 && thin_share <= kMaxThinShareForOneSubcell && band_allows ? 1 : 2;
}

double embedding_indicator_band(const EmbeddingOptions& options, int sub) {
  return std::max(IndicatorOptions::kDefaultBand, std::ceil(stencil_reach(options, sub) / kReachShareOfBand));
}

namespace {

// The embedding of every feature, or of the triple curves and quadruple points alone (curves_only: what the curve
// smoothing measures). owner (optional) receives, per fine point, the feature its closest point ended on.
ClosestPointEmbedding build_embedding(const IndicatorFields& F, const EmbeddingOptions& options, bool curves_only,
                                      HostArray<uint32_t>* owner_out) {
  ClosestPointEmbedding E;
  E.grid = F.grid;
  E.sub = embedding_subcells(options);
  const Grid& grid = F.grid;
  const double h = grid.min_spacing();

  // 1. Features: material sets meeting in a 2x2x2 group of voxels (the dual cell around a grid corner), judged by the
  //    argmax of the fields at the voxel centres (which is each voxel's label). Quadruple-point candidates keep the
  //    dual cell's centre as a Newton start.
  std::map<MaterialKey, std::vector<glm::dvec3>> quad_starts;
  std::map<MaterialKey, std::vector<glm::ivec3>> curve_cells;
  // Every material set found, and where, in bins of kBin^3 voxels (see step 3).
  constexpr int kBin = 4;
  const glm::ivec3 bins = (grid.dims + kBin - 1) / kBin;
  const size_t bin_count = size_t(bins.x) * size_t(bins.y) * size_t(bins.z);
  auto bin_of = [&](int i, int j, int kk) { return (size_t(kk / kBin) * size_t(bins.y) + size_t(j / kBin)) * size_t(bins.x) + size_t(i / kBin); };
  std::map<MaterialKey, std::vector<uint8_t>> found_in;
  std::vector<uint16_t> label_index(grid.voxel_count());
  tbb::parallel_for(fields_brick_rows(F), [&](const tbb::blocked_range2d<int>& r) {
    for_each_voxel_values(F, r, [&](const glm::ivec3& c, std::span<const uint16_t> mats, const float* f) {
      int best = 0;
      float bv = -1e30f;
      for (size_t k = 0; k < mats.size(); ++k)
        if (f[k] > bv) {
          bv = f[k];
          best = mats[k];
        }
      label_index[grid.index(c.x, c.y, c.z)] = uint16_t(best);
    });
  });
  // (Each z layer of dual cells in parallel; the layers' finds are then merged in layer order, so every list keeps the
  // order of one loop over the volume.)
  struct LayerFinds {
    std::map<MaterialKey, std::vector<size_t>> bins;
    std::map<MaterialKey, std::vector<glm::dvec3>> quad_starts;
    std::map<MaterialKey, std::vector<glm::ivec3>> curve_cells;
  };
  std::vector<LayerFinds> layers(size_t(std::max(grid.dims.z - 1, 0)));
  tbb::parallel_for(tbb::blocked_range<int>(0, int(layers.size())), [&](const tbb::blocked_range<int>& r) {
    for (int kk = r.begin(); kk < r.end(); ++kk) {
      LayerFinds& layer = layers[size_t(kk)];
      for (int j = 0; j + 1 < grid.dims.y; ++j)
        for (int i = 0; i + 1 < grid.dims.x; ++i) {
          uint16_t present[8];
          const int n = grid.corner_labels(i, j, kk, [&](size_t v) { return label_index[v]; }, present);
          // Every subset of 2..4 materials present (a corner of more than 4 materials is degenerate; its subsets still count).
          for_each_material_subset(present, n, [&](const MaterialKey& s, int bits) {
            auto& bins_of_set = layer.bins[s];
            if (bins_of_set.empty() || bins_of_set.back() != bin_of(i, j, kk)) bins_of_set.push_back(bin_of(i, j, kk));
            if (bits == 4) layer.quad_starts[s].push_back(grid.local(glm::dvec3(i + 0.5, j + 0.5, kk + 0.5)));
            if (bits == 3) layer.curve_cells[s].push_back(glm::ivec3(i, j, kk));
          });
        }
    }
  });
  for (LayerFinds& layer : layers) {
    for (const auto& [s, where] : layer.bins) {
      auto& found = found_in[s];
      if (found.empty()) found.resize(bin_count, 0);
      for (size_t b : where) found[b] = 1;
    }
    for (auto& [s, starts] : layer.quad_starts) {
      auto& all = quad_starts[s];
      all.insert(all.end(), starts.begin(), starts.end());
    }
    for (auto& [s, cells] : layer.curve_cells) {
      auto& all = curve_cells[s];
      all.insert(all.end(), cells.begin(), cells.end());
    }
    layer = {};
  }
  for (size_t count : {2u, 3u, 4u})
    for (const auto& [s, where] : found_in) {
      const size_t c = size_t(std::count_if(s.begin(), s.end(), [](uint16_t x) { return x != kNone; }));
      if (c == count) E.features.push_back(Feature{kind_of(c), s});
    }
  if (E.features.size() > kMaxFeatures)  // the coarse cells' keys hold the feature in 16 bits
    throw std::runtime_error("the closest point embedding supports at most " + std::to_string(kMaxFeatures) +
                             " features (interfaces, triple curves, quadruple points); this volume has " +
                             std::to_string(E.features.size()));
  std::map<MaterialKey, uint32_t> feature_of;
  for (size_t f = 0; f < E.features.size(); ++f) feature_of[E.features[f].materials] = uint32_t(f);
  for (auto& [s, cells] : curve_cells) E.features[feature_of[s]].components = count_components(cells);

  // 2. Quadruple points: Newton from every candidate dual cell, merged when within a voxel.
  for (const auto& [s, starts] : quad_starts) {
    const Feature& feat = E.features[feature_of[s]];
    std::vector<glm::dvec3> found;
    for (const auto& start : starts) {
      glm::dvec3 p;
      if (!project_to_feature(F, feat, start, p, options.newton_iterations, 1)) continue;
      if (glm::length((p - start) / grid.spacing) > 2.0) continue;  // wandered off: not this candidate's point
      if (std::none_of(found.begin(), found.end(), [&](const glm::dvec3& q) { return glm::length((p - q) / grid.spacing) < 1.0; }))
        found.push_back(p);
    }
    for (const auto& p : found) E.quadruple_points.push_back({feature_of[s], p});
    E.features[feature_of[s]].components = uint32_t(found.size());
  }

  // 3. Coarse cells: a voxel belongs to a feature's band when every material of the feature is within
  //    band + stencil reach of it (f_m > -reach, stencil_reach), so WENO4 stencils around any point within `band`
  //    are complete.
  //    And when the feature was found (step 1) within 2 reach + 1 voxel of it. A point within reach of every
  //    material of a feature lies that close to where they meet, unless another material separates them: across a
  //    thin layer (the CSF between skull and brain) every voxel is within reach of both sides, and where the sides
  //    touch somewhere else the band of their interface and curves would fill the whole layer, with Newton failing
  //    at every fine point there (no such interface nearby), 14 tries of 30 steps each.
  const double reach = stencil_reach(options, E.sub) * h;
  // Voxels i and i + d lie at most floor((d + kBin - 1) / kBin) bins apart.
  const int near_bins = int(std::ceil((2.0 * reach / h + 1.0 + kBin - 1) / kBin));
  std::vector<std::vector<uint8_t>> near_found(E.features.size());
  tbb::parallel_for(size_t(0), E.features.size(), [&](size_t f) {
    std::vector<uint8_t> a = found_in.at(E.features[f].materials), b(bin_count);
    // Separable dilation by near_bins bins along x, y, then z.
    const std::array<size_t, 3> stride = {1, size_t(bins.x), size_t(bins.x) * size_t(bins.y)};
    for (int axis = 0; axis < 3; ++axis) {
      const int len = bins[axis];
      for (size_t v = 0; v < bin_count; ++v) {
        const int pos = int((v / stride[size_t(axis)]) % size_t(len));
        uint8_t any = 0;
        for (int d = std::max(0, pos - near_bins); d <= std::min(len - 1, pos + near_bins) && !any; ++d)
          any = a[v + (size_t(d) - size_t(pos)) * stride[size_t(axis)]];
        b[v] = any;
      }
      std::swap(a, b);
    }
    near_found[f] = std::move(a);
  });
  if (reach >= kReachShareOfBand * F.band)
    throw std::invalid_argument("closest point embedding: band " + std::to_string(options.band) + " voxels plus the " +
                                "WENO4 stencil reach needs indicator fields stored " + std::to_string(reach / h) +
                                " voxels deep, but their band is " + std::to_string(F.band / h) +
                                " voxels; raise the indicator band or use more subcells");
  tbb::enumerable_thread_specific<std::vector<uint64_t>> local_entries;
  tbb::enumerable_thread_specific<size_t> local_blocks(0);  // every feature's, in the curves-only pass too
  tbb::parallel_for(fields_brick_rows(F), [&](const tbb::blocked_range2d<int>& r) {
    auto& out = local_entries.local();
    size_t& blocks = local_blocks.local();
    std::vector<int> near;
    for_each_voxel_values(F, r, [&](const glm::ivec3& c, std::span<const uint16_t> mats, const float* f) {
      near.clear();
      for (size_t k = 0; k < mats.size(); ++k)
        if (f[k] > -reach) near.push_back(mats[k]);
      for_each_material_subset(near.data(), int(std::min<size_t>(near.size(), 8)), [&](const MaterialKey& s, int bits) {
        const auto it = feature_of.find(s);
        if (it == feature_of.end() || !near_found[it->second][bin_of(c.x, c.y, c.z)]) return;
        ++blocks;
        if (!curves_only || bits >= 3) out.push_back((uint64_t(grid.index(c.x, c.y, c.z)) << 16) | it->second);
      });
    });
  });
  if (options.check_blocks) options.check_blocks(local_blocks.combine(std::plus<size_t>()), E.sub);
  std::vector<uint64_t> cells;
  for (auto& part : local_entries) cells.insert(cells.end(), part.begin(), part.end());
  tbb::parallel_sort(cells.begin(), cells.end());

  // 5. Fine level: the closest point of every fine point of every block, by Newton projection on the smooth fields,
  //    restricted to the feature (bounding curves and points take over beyond them).
  //    Where a material set meets in the labels (step 1) but not in the smooth fields (a layer one voxel thin across
  //    a 2x2x2 group, kept whole by the smoothing and tightening), Newton fails at every fine point of its band: 14
  //    runs of 30 steps each. In the curve smoothing's embedding (curves_only) a run that stagnates gives up, the
  //    nudged starts are tried by a block's first point and then only once one of its points has landed, and
  //    blocks where no point landed are dropped (their points are on no curve, and they made every fit around them
  //    fail). On the 100^3 head phantom (2 cores) that pass took a third of the 205 s embedding, with 92% of its
  //    fine points in such blocks; the smoothing then measured 97,733 curve points and moved none, and measures
  //    1,978 now and moves 36.
  //    The full embedding keeps those blocks and their failed points, as before: on the 64^3 shells (1-voxel layers,
  //    no true triple curve) the particles seeded on them sit in the thin layers and keep their two sides apart.
  //    Dropping the blocks (or giving up early there, which moves the failed points) left 194-447 wrong faces
  //    instead of 33 and made 2-4 interfaces non-manifold: the thin layers' meshing must be fixed before this can.
  const int sub = E.sub, per_block = sub * sub * sub;
  E.fine.resize(cells.size() * size_t(per_block));
  HostArray<uint32_t> owner(E.fine.size());  // the feature each fine point's closest point ended on
  std::vector<uint8_t> landed_in(cells.size(), 0);  // per block: some fine point landed
  std::atomic<uint64_t> total_steps{0}, total_failed{0};
  tbb::parallel_for(tbb::blocked_range<size_t>(0, cells.size()), [&](const tbb::blocked_range<size_t>& r) {
    uint64_t steps = 0, failed_points = 0;
    for (size_t b = r.begin(); b < r.end(); ++b) {
      const size_t cell = size_t(cells[b] >> 16);
      const uint32_t fid = uint32_t(cells[b] & 0xffff);
      const glm::ivec3 c = grid.voxel(cell);
      glm::dvec3 warm_gradients[4];
      bool warm_gradients_ok = false;
      bool previous_failed = false;
      for (int q = 0; q < per_block; ++q) {
        const glm::dvec3 ijk = glm::dvec3(c) + glm::dvec3(q % sub, (q / sub) % sub, q / (sub * sub)) / double(sub);
        const glm::dvec3 x0 = grid.local(ijk);
        glm::dvec3 cp = x0;
        // The block's fine points are within a voxel of each other: start from the previous one's closest point
        // (already on the feature), which saves most Newton iterations.
        const glm::dvec3 warm = q > 0 ? glm::dvec3(glm::vec3(E.fine[b * size_t(per_block) + size_t(q - 1)])) : x0;
        // (Where that point failed, where its Newton stopped is still a better start than x0 on a medial surface.)
        const bool warm_ok = q > 0 && E.features[fid].kind != FeatureKind::quadruple_point;
        const bool nudge = !curves_only || q == 0 || landed_in[b];
        // The gradients of this point's projection onto fid (the next point's start, when it lands there).
        glm::dvec3 gradients[4] = {glm::dvec3(0.0), glm::dvec3(0.0), glm::dvec3(0.0), glm::dvec3(0.0)};
        bool landed = false;  // cp is a converged projection onto `feature`, or its located quadruple point
        uint32_t feature = fid;
        // Restriction: at most two escalations (interface -> curve -> point).
        for (int level = 0; level < 3; ++level) {
          const Feature& feat = E.features[feature];
          if (feat.kind == FeatureKind::quadruple_point) {
            double best = 1e300;
            for (const auto& qp : E.quadruple_points) {  // the nearest located point of this material set
              const double d = glm::length(qp.position - x0);
              if (qp.feature == feature && d < best) {
                best = d;
                cp = qp.position;
                landed = true;
              }
            }
            break;
          }
          double own = 0;  // f of the feature's first material at cp: from the projection's last sample when it landed
          const bool from_warm = level == 0 && warm_ok;
          bool ok = project_from(F, feat, x0, cp, options.newton_iterations, options.closest_point_rounds,
                                 from_warm ? &warm : nullptr, from_warm && warm_gradients_ok ? warm_gradients : nullptr,
                                 curves_only, nudge && previous_failed, &own, level == 0 ? gradients : nullptr,
                                 &steps);
          if (ok && level == 0 && feat.kind != FeatureKind::quadruple_point)
            take_nearer_projection(F, feat, x0, options, curves_only, cp, own, gradients, steps);
          // Newton fails where the constraints' gradients vanish: on a medial surface, equally far from two sheets
          // of the feature (the middle of a layer three voxels thick). Any sheet's point will do there; what Newton
          // left behind is not on the feature at all. Starts nudged a third of a voxel along each axis find one.
          // Where every start fails (a material set that meets in the labels but not in the smooth fields: a thin
          // layer), the point keeps where the last start's full-length runs stopped (see above: the thin layers'
          // particles need it). The point after a failed one (it starts where that one stopped) lets every start but
          // the last give up when Newton stagnates: a failed point took 408 steps on average before (7 starts, up to
          // 2 runs of 30), 163 now (fields_embedding_test). Head phantom at 100^3
          // (2 cores): build_fields 64.0 -> 36.2 s; 4,282 of 4.5 M fine points moved, most of them nearer their
          // fine point than before (3,528 against 654: fewer runs that wander off and land on another sheet).
          // A block's first point, every block where no point fails, and where failed points stay are as before.
          for (int d = 0; !ok && nudge && d < 6; ++d) {
            glm::dvec3 nudged = x0;
            nudged[d / 2] += (d % 2 ? -1.0 : 1.0) * grid.spacing[d / 2] / 3.0;
            ok = project_from(F, feat, x0, cp, options.newton_iterations, options.closest_point_rounds, &nudged,
                              nullptr, curves_only, d < 5 && previous_failed, &own, level == 0 ? gradients : nullptr,
                              &steps);
          }
          landed = ok;
          int m[4];
          const int count = materials_of(feat, m);
          if (!ok) own = F.fields[size_t(m[0])].sample_cubic_local(cp);
          int intruder = -1;
          double worst = own + 1e-4 * h;
          const glm::ivec3 nearest = glm::clamp(glm::ivec3(glm::round(cp / grid.spacing)), glm::ivec3(0), grid.dims - 1);
          for (const int mm : F.materials_near(cp / grid.spacing)) {  // no other can rise above the feature's here
            if (std::find(m, m + count, mm) != m + count) continue;
            // The interpolant stays within about a voxel of its nearest sample (distance fields change by at most
            // their spacing per voxel): a material that far below cannot win here, and needs no cubic sample.
            if (F.fields[size_t(mm)].at(nearest.x, nearest.y, nearest.z) < worst - 2.0 * h) continue;
            const double v = F.fields[size_t(mm)].sample_cubic_local(cp);
            if (v > worst) {
              worst = v;
              intruder = mm;
            }
          }
          if (intruder < 0 || count == 4) break;
          std::vector<int> ms(m, m + count);
          ms.push_back(intruder);
          const auto it = feature_of.find(set_of(ms));
          if (it == feature_of.end()) break;
          feature = it->second;
        }
        E.fine[b * size_t(per_block) + size_t(q)] = glm::vec4(glm::vec3(cp), 0.0f);
        owner[b * size_t(per_block) + size_t(q)] = feature;
        // The next point starts from this one's closest point, and on fid from its gradients too.
        warm_gradients_ok = landed && feature == fid;  // (quadruple-point blocks never start warm: warm_ok)
        if (warm_gradients_ok) std::copy(gradients, gradients + 4, warm_gradients);
        landed_in[b] |= uint8_t(landed);
        previous_failed = !landed;
        failed_points += !landed;
      }
    }
    total_steps.fetch_add(steps, std::memory_order_relaxed);
    total_failed.fetch_add(failed_points, std::memory_order_relaxed);
  });
  E.stats.fine_points = E.fine.size();
  E.stats.failed_points = total_failed.load();
  E.stats.newton_steps = total_steps.load();
  if (curves_only) {  // drop the blocks where no point landed (above)
    size_t kept = 0;
    for (size_t b = 0; b < cells.size(); ++b) {
      if (!landed_in[b]) continue;
      cells[kept] = cells[b];
      std::copy_n(E.fine.begin() + ptrdiff_t(b * size_t(per_block)), per_block, E.fine.begin() + ptrdiff_t(kept * size_t(per_block)));
      std::copy_n(owner.begin() + ptrdiff_t(b * size_t(per_block)), per_block, owner.begin() + ptrdiff_t(kept * size_t(per_block)));
      ++kept;
    }
    cells.resize(kept);
    E.fine.resize(kept * size_t(per_block));
    owner.resize(E.fine.size());
  }

  // 6. Hash table (build_hash_table): every key within kMaxProbes of its home slot.
  build_hash_table(cells, ClosestPointEmbedding::kMaxProbes, E.keys, E.blocks);
  if (owner_out) *owner_out = std::move(owner);
  return E;
}

}  // namespace

ClosestPointEmbedding build_closest_point_embedding(const IndicatorFields& F, const EmbeddingOptions& options) {
  return build_embedding(F, options, false, nullptr);
}

std::vector<CurveMove> triple_curve_moves(const IndicatorFields& F, const EmbeddingOptions& options) {
  if (options.curve_smoothing <= 0) return {};
  HostArray<uint32_t> owner;
  const ClosestPointEmbedding curves = build_embedding(F, options, true, &owner);
  return curve_moves(F, curves, owner, options.curve_smoothing * F.grid.min_spacing(), options.junction_extrapolation);
}

size_t warp_fields(IndicatorFields& F, const std::vector<CurveMove>& moves) {
  if (std::none_of(moves.begin(), moves.end(), [](const CurveMove& m) { return glm::length(m.move) > 0; })) return 0;
  const Grid& grid = F.grid;
  const double h = grid.min_spacing();
  constexpr double kFull = 1.0, kReach = 3.5, kKernel = 1.0;  // voxels: full move within kFull, none beyond kReach
  // The voxels within reach of a moved curve point.
  std::vector<uint8_t> near(grid.voxel_count(), 0);
  const glm::ivec3 reach = glm::ivec3(glm::ceil(kReach * h / grid.spacing));
  for (uint32_t r = 0; r < moves.size(); ++r) {
    if (glm::length(moves[r].move) == 0) continue;
    const glm::ivec3 v = glm::ivec3(glm::round(moves[r].position / grid.spacing));
    const glm::ivec3 lo = glm::max(v - reach, glm::ivec3(0)), hi = glm::min(v + reach, grid.dims - 1);
    for (int k = lo.z; k <= hi.z; ++k)
      for (int j = lo.y; j <= hi.y; ++j)
        for (int i = lo.x; i <= hi.x; ++i) near[grid.index(i, j, k)] = 1;
  }
  std::vector<size_t> voxels;
  for (size_t v = 0; v < near.size(); ++v)
    if (near[v]) voxels.push_back(v);
  // The displacement at each such voxel: the kernel-weighted mean move of the curve points within kReach, times a
  // fade from 1 within kFull of the nearest curve point (any curve's, moved or not) to 0 at kReach.
  std::vector<glm::dvec3> shift(voxels.size(), glm::dvec3(0.0));
  // Every curve point, in buckets kReach voxels wide.
  const PointBuckets buckets(moves.size(), [&](size_t r) { return moves[r].position; }, kReach * h);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, voxels.size()), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t n = range.begin(); n < range.end(); ++n) {
      const glm::ivec3 v = grid.voxel(voxels[n]);
      const glm::dvec3 x = grid.local(glm::dvec3(v));
      glm::dvec3 sum(0.0);
      double weight = 0, nearest = std::numeric_limits<double>::infinity();
      buckets.for_each_candidate(x, [&](uint32_t r) {
        const double d = glm::length(moves[r].position - x) / h;
        if (d >= kReach) return;
        nearest = std::min(nearest, d);
        const double w = std::exp(-0.5 * d * d / (kKernel * kKernel));
        sum += w * moves[r].move;
        weight += w;
      });
      if (weight <= 0) continue;
      const double t = std::clamp((kReach - nearest) / (kReach - kFull), 0.0, 1.0);
      shift[n] = sum / weight * (t * t * (3 - 2 * t));
    }
  });
  // Every field takes its value at x - shift(x) (Catmull-Rom, from a copy of itself).
  size_t changed = 0;
  for (auto& field : F.fields) {
    const BrickField before = field;
    std::vector<float> value(voxels.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, voxels.size()), [&](const tbb::blocked_range<size_t>& range) {
      for (size_t n = range.begin(); n < range.end(); ++n) {
        const glm::ivec3 v = grid.voxel(voxels[n]);
        value[n] = glm::length(shift[n]) > 0 ? float(before.sample_cubic_local(grid.local(glm::dvec3(v)) - shift[n]))
                                             : before.at(v.x, v.y, v.z);
      }
    });
    for (size_t n = 0; n < voxels.size(); ++n) {
      const glm::ivec3 v = grid.voxel(voxels[n]);
      if (value[n] == before.at(v.x, v.y, v.z)) continue;
      field.set(v.x, v.y, v.z, std::clamp(value[n], float(-F.band), float(F.band)));
      ++changed;
    }
  }
  return changed;
}

CurveSmoothing smooth_triple_curves(IndicatorFields& F, const EmbeddingOptions& options) {
  const auto moves = triple_curve_moves(F, options);
  CurveSmoothing out;
  out.curve_points = moves.size();
  for (const auto& m : moves) {
    const double d = glm::length(m.move / F.grid.min_spacing());
    out.moved_points += d > 0;
    out.extrapolated_points += m.extrapolated;
    out.largest_move = std::max(out.largest_move, d);
  }
  out.changed_values = warp_fields(F, moves);
  return out;
}

}  // namespace cpmesh::fields
