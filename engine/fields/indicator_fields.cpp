#include "fields/indicator_fields.h"

#include <algorithm>
#include <cstdint>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <tuple>
#include <span>

#include <tbb/blocked_range.h>
#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "fields/distance_transform.h"
#include "host/disjoint_sets.h"
#include "host/host_array.h"

namespace cpmesh::fields {

namespace {

struct Box {
  glm::ivec3 lo{std::numeric_limits<int>::max()}, hi{std::numeric_limits<int>::min()};  // inclusive
  glm::ivec3 size() const { return hi - lo + 1; }
};

}  // namespace

// Lines in parallel. Along y and z the lines are taken kLanes neighbours in x at a time: each step along the line
// reads kLanes consecutive floats instead of one per cache line, and the lanes' sums vectorize. Every lane adds the
// same terms in the same order as a line on its own, so the result is the same to the bit.
void gaussian_pass(std::span<float> f, const glm::ivec3& n, int axis, double sigma) {
  if (sigma <= 0) return;
  const int radius = int(std::ceil(3.0 * sigma));
  std::vector<double> w(size_t(2 * radius + 1));
  double total = 0;
  for (int r = -radius; r <= radius; ++r) total += w[size_t(r + radius)] = std::exp(-0.5 * r * r / (sigma * sigma));
  for (auto& x : w) x /= total;
  const int len = n[axis];
  const int a = axis == 0 ? 1 : 0, b = axis == 2 ? 1 : 2;
  const size_t strides[3] = {1, size_t(n.x), size_t(n.x) * size_t(n.y)};
  const size_t s = strides[axis];
  // One group of `lanes` neighbouring lines (at most kWidth, the interleaving of `line`; more than one only along y
  // and z, where a is x), in place. A constant line (far inside or outside, clamped at the band) is left as it is:
  // the weights sum to one, and their rounding is far below a float's.
  constexpr int kLanes = 8;
  auto blur_lines = [&]<int kWidth>(float* p, int lanes, std::vector<float>& line) {
    bool constant[kWidth];
    for (int l = 0; l < kWidth; ++l) constant[l] = true;
    for (int q = 0; q < len; ++q)
      for (int l = 0; l < kWidth; ++l) {
        const float v = l < lanes ? p[size_t(q) * s + size_t(l)] : 0.0f;
        line[size_t(q) * kWidth + size_t(l)] = v;
        constant[l] = constant[l] && v == line[size_t(l)];
      }
    if (std::all_of(constant, constant + lanes, [](bool c) { return c; })) return;
    for (int q = 0; q < len; ++q) {
      double acc[kWidth] = {};
      if (q >= radius && q + radius < len) {  // the kernel inside the line: no clamping (same sum, same order)
        const float* at = line.data() + size_t(q - radius) * kWidth;
        for (int k = 0; k <= 2 * radius; ++k)
          for (int l = 0; l < kWidth; ++l) acc[l] += w[size_t(k)] * at[size_t(k) * kWidth + size_t(l)];
      } else {
        for (int r2 = -radius; r2 <= radius; ++r2) {
          const float* at = line.data() + size_t(std::clamp(q + r2, 0, len - 1)) * kWidth;
          for (int l = 0; l < kWidth; ++l) acc[l] += w[size_t(r2 + radius)] * at[l];
        }
      }
      for (int l = 0; l < lanes; ++l)
        if (!constant[l]) p[size_t(q) * s + size_t(l)] = float(acc[l]);
    }
  };
  const int groups = axis == 0 ? n[a] : (n.x + kLanes - 1) / kLanes;  // along y and z, a is x: kLanes lines a group
  tbb::parallel_for(tbb::blocked_range2d<int>(0, n[b], 0, groups), [&](const tbb::blocked_range2d<int>& r) {
    std::vector<float> line(static_cast<size_t>(len) * kLanes);
    for (int jb = r.rows().begin(); jb < r.rows().end(); ++jb)
      for (int g = r.cols().begin(); g < r.cols().end(); ++g) {
        const int ja = axis == 0 ? g : g * kLanes;
        float* p = f.data() + size_t(jb) * strides[b] + size_t(ja) * strides[a];
        if (axis == 0)
          blur_lines.template operator()<1>(p, 1, line);
        else
          blur_lines.template operator()<kLanes>(p, std::min(kLanes, n.x - ja), line);
      }
  });
}

namespace {

double smoothstep01(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}

// r-tightening of one material's field (a dense crop of n voxels): a curvature-limited level-set flow
//   phi_t = |grad phi| * sum_i (k_i - clamp(k_i, -1/r, 1/r)) * weight
// with k_i the principal curvatures of the level sets (from the Hessian: the mean curvature div(grad phi/|grad phi|)
// and the Gaussian curvature grad^T adj(Hess) grad / |grad|^4), clamped to the r-tube |phi - phi0| <= r. Convex
// bumps sharper than r shrink, concave dents sharper than r fill, flat and gently curved surfaces do not move.
// The flow for -phi is the flow for phi negated, so the two fields of an interface move together.
// weight(ci) in [0, 1] fades the flow out (junctions, protected thin parts). Returns nothing; phi is updated.
template <class Weight>
void tighten_field(std::span<float> phi, const glm::ivec3& n, const glm::dvec3& spacing, double r, int iterations,
                   double band, Weight weight) {
  const double h = std::min({spacing.x, spacing.y, spacing.z});
  const double kmax = 1.0 / r;
  const double dt = 0.12 * h * h;  // explicit curvature flow: stable below h^2 / 6
  const size_t sx = 1, sy = size_t(n.x), sz = size_t(n.x) * size_t(n.y);
  // The voxels the flow may touch: interior of the crop, within r + 2 voxels of the surface, weight > 0.
  const auto found = collect_in_order<std::pair<size_t, float>>(n.z - 2, [&](int layer, auto& out) {
    const int k = layer + 1;
    for (int j = 1; j + 1 < n.y; ++j)
      for (int i = 1; i + 1 < n.x; ++i) {
        const size_t ci = size_t(k) * sz + size_t(j) * sy + size_t(i);
        if (std::fabs(phi[ci]) >= r + 2 * h) continue;
        const double wi = weight(ci);
        if (wi > 0) out.emplace_back(ci, float(wi));
      }
  });
  if (found.empty()) return;
  std::vector<size_t> active(found.size());
  std::vector<float> w(found.size());
  for (size_t a = 0; a < found.size(); ++a) std::tie(active[a], w[a]) = found[a];
  std::vector<float> phi0(active.size()), next(active.size());
  for (size_t a = 0; a < active.size(); ++a) phi0[a] = phi[active[a]];
  const double ix = 1 / spacing.x, iy = 1 / spacing.y, iz = 1 / spacing.z;
  // A voxel's next value depends on its stencil (itself and its 18 face and edge neighbours) and its own phi0 and
  // weight: where no value in the stencil changed in the last step, it would come out as it is. So each step after
  // the first computes only the voxels near one that changed (`dirty`): the flow moves the few places sharper than
  // r, and most of the band is done after a step or two. The same values as computing every voxel every step.
  std::vector<uint8_t> dirty(phi.size(), 0);
  for (size_t ci : active) dirty[ci] = 1;
  std::vector<uint8_t> changed(active.size(), 0);
  for (int it = 0; it < iterations; ++it) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, active.size()), [&](const tbb::blocked_range<size_t>& range) {
      for (size_t a = range.begin(); a < range.end(); ++a) {
        if (!dirty[active[a]]) {
          next[a] = phi[active[a]];
          continue;
        }
        const float* p = phi.data() + active[a];
        auto at = [&](long dx, long dy, long dz) { return double(p[dx * long(sx) + dy * long(sy) + dz * long(sz)]); };
        const double c = at(0, 0, 0);
        const double fx = 0.5 * (at(1, 0, 0) - at(-1, 0, 0)) * ix;
        const double fy = 0.5 * (at(0, 1, 0) - at(0, -1, 0)) * iy;
        const double fz = 0.5 * (at(0, 0, 1) - at(0, 0, -1)) * iz;
        const double hxx = (at(1, 0, 0) - 2 * c + at(-1, 0, 0)) * ix * ix;
        const double hyy = (at(0, 1, 0) - 2 * c + at(0, -1, 0)) * iy * iy;
        const double hzz = (at(0, 0, 1) - 2 * c + at(0, 0, -1)) * iz * iz;
        const double hxy = 0.25 * (at(1, 1, 0) - at(1, -1, 0) - at(-1, 1, 0) + at(-1, -1, 0)) * ix * iy;
        const double hxz = 0.25 * (at(1, 0, 1) - at(1, 0, -1) - at(-1, 0, 1) + at(-1, 0, -1)) * ix * iz;
        const double hyz = 0.25 * (at(0, 1, 1) - at(0, 1, -1) - at(0, -1, 1) + at(0, -1, -1)) * iy * iz;
        const double g2 = fx * fx + fy * fy + fz * fz;
        double value = c;
        if (g2 > 1e-12) {
          const double ghg = fx * fx * hxx + fy * fy * hyy + fz * fz * hzz +
                             2 * (fx * fy * hxy + fx * fz * hxz + fy * fz * hyz);
          const double ksum = (g2 * (hxx + hyy + hzz) - ghg) / (g2 * std::sqrt(g2));
          const double gag = fx * fx * (hyy * hzz - hyz * hyz) + fy * fy * (hxx * hzz - hxz * hxz) +
                             fz * fz * (hxx * hyy - hxy * hxy) +
                             2 * (fx * fy * (hxz * hyz - hxy * hzz) + fx * fz * (hxy * hyz - hxz * hyy) +
                                  fy * fz * (hxy * hxz - hxx * hyz));
          const double gauss = gag / (g2 * g2);
          const double disc = std::sqrt(std::max(0.25 * ksum * ksum - gauss, 0.0));
          const double k1 = 0.5 * ksum + disc, k2 = 0.5 * ksum - disc;
          const double excess = (k1 - std::clamp(k1, -kmax, kmax)) + (k2 - std::clamp(k2, -kmax, kmax));
          value = c + dt * std::sqrt(g2) * excess * w[a];
        }
        next[a] = float(std::clamp(value, std::max(phi0[a] - r, -band), std::min(phi0[a] + r, band)));
      }
    });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, active.size()), [&](const tbb::blocked_range<size_t>& range) {
      for (size_t a = range.begin(); a < range.end(); ++a) {
        // (Bitwise, as a value that did not change reproduces itself bit for bit.)
        changed[a] = std::memcmp(&next[a], &phi[active[a]], sizeof(float)) != 0;
        dirty[active[a]] = 0;
        phi[active[a]] = next[a];
      }
    });
    // The stencils that hold a changed voxel: one with a changed voxel among its 18 neighbours or at its centre.
    bool any = false;
    for (size_t a = 0; a < active.size(); ++a) {
      if (!changed[a]) continue;
      any = true;
      const size_t ci = active[a];
      for (long dz = -1; dz <= 1; ++dz)
        for (long dy = -1; dy <= 1; ++dy)
          for (long dx = -1; dx <= 1; ++dx)
            if (std::abs(dx) + std::abs(dy) + std::abs(dz) <= 2)
              dirty[size_t(long(ci) + dx * long(sx) + dy * long(sy) + dz * long(sz))] = 1;
    }
    if (!any) break;
  }
}

// The labels around each junction corner and their shares of a ball of kAngleBall voxels: 2 pi times a share is the
// label's wedge angle at the junction (a flat side: 1/2).
constexpr double kAngleBall = 3.0;
constexpr float kThinCornerShare = 0.2;
constexpr int kMaxCornerLabels = 8;
struct CornerShares {
  std::array<uint16_t, kMaxCornerLabels> label{};
  std::array<float, kMaxCornerLabels> share{};
  int count = 0;
  float thin = 0;  // share of the ball's voxels in thin parts (protected_distance 0)
};

// protected_distance: squared distance to the nearest thin-part voxel (empty: none known).
std::vector<CornerShares> corner_shares(const Grid& grid, const uint16_t* labels, const std::vector<glm::ivec3>& corners,
                                        std::span<const float> protected_distance) {
  const double h = grid.min_spacing();
  // The shares are taken around the mean of the junction corners within two voxels rather than around the corner
  // itself: a staircase of corners zigzags up to a voxel off the curve, and a ball a voxel off a wedge's apex gets
  // a share that is wrong by about 2 / (pi * radius).
  std::vector<uint8_t> is_corner(grid.voxel_count(), 0);
  for (const auto& c : corners) is_corner[grid.index(c.x, c.y, c.z)] = 1;
  const glm::ivec3 reach = glm::ivec3(glm::ceil(kAngleBall * h / grid.spacing)) + 2;
  std::vector<CornerShares> out(corners.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, corners.size()), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t ci = r.begin(); ci < r.end(); ++ci) {
      auto& c = out[ci];
      const glm::ivec3 k0 = corners[ci];
      glm::dvec3 mean(0.0);
      int found = 0;
      for (int z = -2; z <= 2; ++z)
        for (int y = -2; y <= 2; ++y)
          for (int x = -2; x <= 2; ++x) {
            const glm::ivec3 q = k0 + glm::ivec3(x, y, z);
            if (!grid.inside(q.x, q.y, q.z) || x * x + y * y + z * z > 4 || !is_corner[grid.index(q.x, q.y, q.z)]) continue;
            mean += glm::dvec3(q) + 0.5;
            ++found;
          }
      const glm::dvec3 centre = mean / double(std::max(found, 1));  // voxel-index coordinates
      std::array<int, kMaxCornerLabels> counts{};
      int total = 0, thin = 0;
      const glm::ivec3 lo = glm::max(k0 - reach, glm::ivec3(0)), hi = glm::min(k0 + reach, grid.dims - 1);
      for (int z = lo.z; z <= hi.z; ++z)
        for (int y = lo.y; y <= hi.y; ++y)
          for (int x = lo.x; x <= hi.x; ++x) {
            if (glm::length((glm::dvec3(x, y, z) - centre) * grid.spacing) > kAngleBall * h) continue;
            const uint16_t l = labels[grid.index(x, y, z)];
            int a = 0;
            while (a < c.count && c.label[size_t(a)] != l) ++a;
            if (a == c.count) {
              if (c.count == kMaxCornerLabels) continue;  // a ninth label near one corner: left out of the shares
              c.label[size_t(c.count++)] = l;
            }
            ++counts[size_t(a)];
            ++total;
            thin += !protected_distance.empty() && protected_distance[grid.index(x, y, z)] == 0;
          }
      for (int a = 0; a < c.count; ++a) c.share[size_t(a)] = float(double(counts[size_t(a)]) / double(std::max(total, 1)));
      c.thin = float(double(thin) / double(std::max(total, 1)));
    }
  });
  return out;
}

// The wedge-angle correction's data: per junction corner, the offset each label's field gets there,
// amplitude * k(2 pi * share) (see the header), with the labels of `shares`.
struct JunctionAngles {
  struct Corner {
    std::array<uint16_t, kMaxCornerLabels> label{};
    std::array<float, kMaxCornerLabels> offset{};
    int count = 0;
  };
  std::vector<Corner> corners;
};

JunctionAngles junction_angles(const std::vector<CornerShares>& shares, const std::vector<uint8_t>& corner_labels,
                               double amplitude) {
  JunctionAngles out;
  out.corners.resize(shares.size());
  for (size_t ci = 0; ci < shares.size(); ++ci) {
    // Where four or more labels meet, no wedge angle describes a material: those corners give no offset, and the
    // offsets there are the average of the triple curves' around them.
    // Nor do corners among thin parts: where a layer a voxel or two thick lets its two neighbours touch, the corners
    // are its staircase, not a wedge, and an offset there can cut the layer. A wedge's apex has a few thin voxels;
    // a layer fills its share of the ball with them.
    if (corner_labels[ci] > 3 || shares[ci].thin > kThinCornerShare) continue;
    auto& c = out.corners[ci];
    c.count = shares[ci].count;
    c.label = shares[ci].label;
    for (int a = 0; a < c.count; ++a) {
      const double half_angle = std::numbers::pi * double(shares[ci].share[size_t(a)]);
      c.offset[size_t(a)] = float(-amplitude * (half_angle - std::numbers::pi / 2 - std::cos(half_angle)) / std::numbers::pi);
    }
  }
  return out;
}

// Adds the wedge-angle offset of one material near junctions to its field, and returns the offset as a sparse field
// (0 elsewhere): the corners' offsets for this label, averaged with weights (1 - (d/R)^2)^2 over corners within
// R = fade + 1.5 voxels, times a fade that is 1 within a voxel of a junction and 0 beyond fade + 1 voxel, and 0 where
// the field is at the band's edge. Every voxel of the field keeps its sign (+-keep(voxel) at least).
BrickField add_junction_offset(uint16_t label, BrickField& field, double band,
                               const std::function<float(size_t)>& keep, const std::vector<glm::ivec3>& corners, const JunctionAngles& angles,
                               std::span<const float> junction_distance, const Grid& grid, double fade) {
  const double h = grid.min_spacing();
  const double radius = fade + 1.5 * h;
  const glm::ivec3 reach = glm::ivec3(glm::ceil(radius / grid.spacing)) + 1;
  BrickField out(grid, 0.0f);
  // Sums per touched brick: sparse, since junctions are curves.
  std::map<size_t, std::pair<std::vector<float>, std::vector<float>>> sums;  // brick index -> (num, den)
  const glm::ivec3 bdims = out.brick_dims();
  for (size_t ci = 0; ci < corners.size(); ++ci) {
    const auto& c = angles.corners[ci];
    int a = 0;
    while (a < c.count && c.label[size_t(a)] != label) ++a;
    if (a == c.count) continue;
    const float offset = c.offset[size_t(a)];
    const glm::dvec3 centre = glm::dvec3(corners[ci]) + 0.5;  // voxel-index coordinates
    const glm::ivec3 v0 = glm::max(corners[ci] - reach, glm::ivec3(0));
    const glm::ivec3 v1 = glm::min(corners[ci] + reach, grid.dims - 1);
    for (int k = v0.z; k <= v1.z; ++k)
      for (int j = v0.y; j <= v1.y; ++j)
        for (int i = v0.x; i <= v1.x; ++i) {
          const double d = glm::length((glm::dvec3(i, j, k) - centre) * grid.spacing) / radius;
          if (d >= 1) continue;
          const float w = float((1 - d * d) * (1 - d * d));
          const glm::ivec3 b = glm::ivec3(i, j, k) / BrickField::kBrick, o = glm::ivec3(i, j, k) - b * BrickField::kBrick;
          auto& [num, den] = sums[(size_t(b.z) * size_t(bdims.y) + size_t(b.y)) * size_t(bdims.x) + size_t(b.x)];
          if (num.empty()) num.assign(BrickField::kBrickVoxels, 0.0f), den.assign(BrickField::kBrickVoxels, 0.0f);
          const size_t q = size_t((o.z * BrickField::kBrick + o.y) * BrickField::kBrick + o.x);
          num[q] += w * offset;
          den[q] += w;
        }
  }
  for (const auto& [bi, nd] : sums) {
    const glm::ivec3 b(int(bi % size_t(bdims.x)), int(bi / size_t(bdims.x) % size_t(bdims.y)),
                       int(bi / (size_t(bdims.x) * size_t(bdims.y))));
    out.allocate(b);
    for (int q = 0; q < BrickField::kBrickVoxels; ++q) {
      if (nd.second[size_t(q)] <= 0) continue;
      const glm::ivec3 v = b * BrickField::kBrick + glm::ivec3(q % BrickField::kBrick, q / BrickField::kBrick % BrickField::kBrick,
                                                               q / (BrickField::kBrick * BrickField::kBrick));
      if (!grid.inside(v.x, v.y, v.z)) continue;
      const double dj = std::sqrt(double(junction_distance[grid.index(v.x, v.y, v.z)]));
      // None where the field is clamped at the band's edge: a raised -band would tie with other materials' far values.
      const float f = field.at(v.x, v.y, v.z);
      const double w = (1 - smoothstep01((dj - h) / fade)) * std::clamp((band - std::fabs(double(f))) / h, 0.0, 1.0);
      const float o = float(w * nd.first[size_t(q)] / nd.second[size_t(q)]);
      out.set(v.x, v.y, v.z, o);
      if (o == 0) continue;
      const float g = std::clamp(f + o, float(-band), float(band));
      const float k = keep(grid.index(v.x, v.y, v.z));
      field.set(v.x, v.y, v.z, f > 0 ? std::max(g, k) : std::min(g, -k));
    }
  }
  return out;
}

// Per voxel: 1 where it is protected (protected_distance 0) and its label's face-connected component has at most
// max_voxels voxels and one label around it across faces (an island in one material, or in the outside); empty when
// none can be (max_voxels 0 or no thin parts measured).
HostArray<uint8_t> thin_islands(const Grid& grid, const uint16_t* labels, std::span<const float> protected_distance,
                                size_t max_voxels) {
  if (max_voxels == 0 || protected_distance.empty()) return {};
  const size_t n = grid.voxel_count();
  DisjointSets sets(n);
  const glm::ivec3 d = grid.dims;
  tbb::parallel_for(tbb::blocked_range<int>(0, d.z), [&](const tbb::blocked_range<int>& r) {
    for (int k = r.begin(); k < r.end(); ++k)
      for (int j = 0; j < d.y; ++j)
        for (int i = 0; i < d.x; ++i) {
          const size_t v = grid.index(i, j, k);
          if (i + 1 < d.x && labels[v] == labels[grid.index(i + 1, j, k)]) sets.join(uint32_t(v), uint32_t(grid.index(i + 1, j, k)));
          if (j + 1 < d.y && labels[v] == labels[grid.index(i, j + 1, k)]) sets.join(uint32_t(v), uint32_t(grid.index(i, j + 1, k)));
          if (k + 1 < d.z && labels[v] == labels[grid.index(i, j, k + 1)]) sets.join(uint32_t(v), uint32_t(grid.index(i, j, k + 1)));
        }
  });
  // Per component (at its root): its voxels, and the label around it (kMixed: more than one; the outside is 0).
  constexpr uint32_t kNone = 0xffffffffu, kMixed = 0xfffffffeu;
  HostArray<uint32_t> size = filled(n, uint32_t(0)), around = filled(n, kNone);
  for (int k = 0; k < d.z; ++k)
    for (int j = 0; j < d.y; ++j)
      for (int i = 0; i < d.x; ++i) {
        const size_t v = grid.index(i, j, k);
        const uint32_t root = sets.find(uint32_t(v));
        ++size[root];
        const glm::ivec3 q[6] = {{i - 1, j, k}, {i + 1, j, k}, {i, j - 1, k}, {i, j + 1, k}, {i, j, k - 1}, {i, j, k + 1}};
        for (const glm::ivec3& w : q) {
          const uint32_t other = grid.inside(w.x, w.y, w.z) ? labels[grid.index(w.x, w.y, w.z)] : 0u;
          if (grid.inside(w.x, w.y, w.z) && other == labels[v]) continue;
          around[root] = around[root] == kNone || around[root] == other ? other : kMixed;
        }
      }
  HostArray<uint8_t> out = filled(n, uint8_t(0));
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v < r.end(); ++v) {
      const uint32_t root = sets.find(uint32_t(v));
      out[v] = protected_distance[v] == 0 && size[root] <= max_voxels && around[root] != kMixed;
    }
  });
  return out;
}

}  // namespace

std::span<const uint16_t> IndicatorFields::materials_near(const glm::dvec3& ijk) const {
  if (fields.empty()) return {};
  const glm::ivec3 bricks = fields[0].brick_dims();
  const glm::ivec3 v = glm::clamp(glm::ivec3(glm::floor(ijk)), glm::ivec3(0), grid.dims - 1);
  const size_t i = fields[0].brick_index(glm::min(v / BrickField::kBrick, bricks - 1));
  return std::span(near_list.data() + near_begin[i], near_begin[i + 1] - near_begin[i]);
}

int IndicatorFields::material_at(const glm::dvec3& ijk) const {
  int best = 0;
  double best_value = -std::numeric_limits<double>::infinity();
  constexpr size_t kBatch = 16;  // fields sampled together
  const BrickField* batch[kBatch];
  double values[kBatch];
  const std::span<const uint16_t> near = materials_near(ijk);
  for (size_t first = 0; first < near.size(); first += kBatch) {
    const size_t count = std::min(kBatch, near.size() - first);
    for (size_t k = 0; k < count; ++k) batch[k] = &fields[near[first + k]];
    BrickField::sample_linear_many(batch, int(count), ijk, values);
    for (size_t k = 0; k < count; ++k)
      if (values[k] > best_value) {
        best_value = values[k];
        best = int(near[first + k]);
      }
  }
  return best;
}

void index_materials_near(IndicatorFields& F) {
  F.near_begin.assign(1, 0);
  F.near_list.clear();
  if (F.fields.empty()) return;
  const glm::ivec3 bricks = F.fields[0].brick_dims();
  const float floor = -float(F.band);
  auto index = [&](const glm::ivec3& b) { return F.fields[0].brick_index(b); };
  // Per brick, the materials present in it; then each brick's list is the union over its 3x3x3 neighbourhood.
  std::vector<std::vector<uint16_t>> in(size_t(bricks.x) * size_t(bricks.y) * size_t(bricks.z));
  for (size_t m = 0; m < F.fields.size(); ++m)
    for (int z = 0; z < bricks.z; ++z)
      for (int y = 0; y < bricks.y; ++y)
        for (int x = 0; x < bricks.x; ++x) {
          const glm::ivec3 b(x, y, z);
          if (F.fields[m].allocated(b) || F.fields[m].brick_constant(b) > floor) in[index(b)].push_back(uint16_t(m));
        }
  std::vector<uint16_t> near;
  for (int z = 0; z < bricks.z; ++z)
    for (int y = 0; y < bricks.y; ++y)
      for (int x = 0; x < bricks.x; ++x) {
        near.clear();
        const glm::ivec3 lo = glm::max(glm::ivec3(x, y, z) - 1, glm::ivec3(0));
        const glm::ivec3 hi = glm::min(glm::ivec3(x, y, z) + 1, bricks - 1);
        for (int c = lo.z; c <= hi.z; ++c)
          for (int b = lo.y; b <= hi.y; ++b)
            for (int a = lo.x; a <= hi.x; ++a) {
              const auto& here = in[index({a, b, c})];
              near.insert(near.end(), here.begin(), here.end());
            }
        std::sort(near.begin(), near.end());
        near.erase(std::unique(near.begin(), near.end()), near.end());
        F.near_list.insert(F.near_list.end(), near.begin(), near.end());
        F.near_begin.push_back(uint32_t(F.near_list.size()));
      }
}

size_t IndicatorFields::memory_bytes() const {
  size_t total = 0;
  for (const auto& f : fields) total += f.memory_bytes();
  for (const auto& f : junction_offsets) total += f.memory_bytes();
  return total;
}

IndicatorFields build_indicator_fields(const Grid& grid, const uint16_t* labels, const IndicatorOptions& options) {
  IndicatorFields out;
  out.grid = grid;
  const double h = grid.min_spacing();
  const double band_voxels = options.band > 0 ? options.band : IndicatorOptions::kDefaultBand;
  out.band = band_voxels * h;
  const float band = float(out.band);

  // Labels present, their voxel counts and bounding boxes.
  // (Slabs of z in parallel; each row's runs of one label as one entry.)
  using LabelInfo = std::map<uint16_t, std::pair<uint64_t, Box>>;
  const LabelInfo found = tbb::parallel_reduce(
      tbb::blocked_range<int>(0, grid.dims.z), LabelInfo{},
      [&](const tbb::blocked_range<int>& r, LabelInfo acc) {
        for (int k = r.begin(); k < r.end(); ++k)
          for (int j = 0; j < grid.dims.y; ++j) {
            const uint16_t* row = labels + grid.index(0, j, k);
            for (int i = 0; i < grid.dims.x;) {
              int end = i + 1;
              while (end < grid.dims.x && row[end] == row[i]) ++end;
              auto& [count, box] = acc[row[i]];
              count += uint64_t(end - i);
              box.lo = glm::min(box.lo, glm::ivec3(i, j, k));
              box.hi = glm::max(box.hi, glm::ivec3(end - 1, j, k));
              i = end;
            }
          }
        return acc;
      },
      [](LabelInfo a, const LabelInfo& b) {
        for (const auto& [label, info] : b) {
          auto& [count, box] = a[label];
          count += info.first;
          box.lo = glm::min(box.lo, info.second.lo);
          box.hi = glm::max(box.hi, info.second.hi);
        }
        return a;
      });

  // Distance to the junctions (voxel corners where three or more labels meet). Near them the smoothing changes:
  // smoothing each material's distance field alone rounds every wedge-shaped edge of a material and so moves
  // triple curves and quadruple points (about 0.5 voxel into the convex side at sigma = 1).
  HostArray<float> junction_distance;
  std::vector<glm::ivec3> junction_corners;  // lowest voxel of each 2x2x2 block with three or more labels
  std::vector<uint8_t> junction_corner_labels;  // how many
  if (options.junction_fade > 0) {
    junction_distance = filled(grid.voxel_count(), std::numeric_limits<float>::infinity());
    const auto corners = collect_in_order<std::pair<glm::ivec3, uint8_t>>(grid.dims.z - 1, [&](int k, auto& out) {
      for (int j = 0; j + 1 < grid.dims.y; ++j)
        for (int i = 0; i + 1 < grid.dims.x; ++i) {
          uint16_t seen[8];
          const int present = grid.corner_labels(i, j, k, [&](size_t v) { return labels[v]; }, seen);
          if (present >= 3) out.emplace_back(glm::ivec3(i, j, k), uint8_t(present));
        }
    });
    for (const auto& [v, present] : corners) {
      junction_corners.push_back(v);
      junction_corner_labels.push_back(present);
      for (int c = 0; c < 8; ++c) junction_distance[grid.index(v.x + (c & 1), v.y + ((c >> 1) & 1), v.z + (c >> 2))] = 0;
    }
    // (Read up to fade + h: the twicing's and correction's weights are 1 beyond fade, the junction offsets 0
    // beyond fade + h.)
    squared_distance_transform(grid, junction_distance, (options.junction_fade + 1) * h);
  }
  const double fade = options.junction_fade * h;
  const double sigma_phys = options.smoothing_sigma * h;
  const double tighten_r = options.tighten_radius * h;
  const int margin = int(std::ceil(std::max(band_voxels + 3.0 * options.smoothing_sigma, 2.0 * options.tighten_radius))) + 2;
  auto crop_of = [&](const Box& box) {
    return Box{glm::max(box.lo - margin, glm::ivec3(0)), glm::min(box.hi + margin, grid.dims - 1)};
  };

  // Thin parts, protected from tightening: voxels of a material with no voxel at least r deep inside it (its "core")
  // within 2r. Sheets and vessels thinner than about 2r and components smaller than r have no core; a cube's corners
  // lie r*sqrt(3) from its core and are rounded. The flow fades in over r + 1 voxels around protected voxels, for
  // every material, so no neighbour grows into a protected part either.
  // The junction correction uses the same test (with r = 1 voxel if tightening is off): a layer a voxel or two thick
  // has junction corners wherever its staircase lets its two neighbours touch, and an offset there can cut it.
  const double thin_r = tighten_r > 0 ? tighten_r : options.junction_correction > 0 || options.island_margin > 0 ? h : 0.0;
  out.thin_radius = thin_r / h;
  HostArray<float> protected_distance;
  if (thin_r > 0) {
    protected_distance = filled(grid.voxel_count(), std::numeric_limits<float>::infinity());
    for (const auto& [label, info] : found) {
      const Box crop = crop_of(info.second);
      const glm::ivec3 n = crop.size();
      Grid cgrid{n, grid.spacing, grid.origin};
      const size_t cn = cgrid.voxel_count();
      HostArray<float> depth(cn), to_core(cn);
      auto full_index = [&](size_t ci) {
        const glm::ivec3 v = crop.lo + cgrid.voxel(ci);
        return grid.index(v.x, v.y, v.z);
      };
      tbb::parallel_for(tbb::blocked_range<size_t>(0, cn), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t ci = r.begin(); ci < r.end(); ++ci)
          depth[ci] = labels[full_index(ci)] == label ? std::numeric_limits<float>::infinity() : 0.0f;
      });
      squared_distance_transform(cgrid, depth, thin_r + 0.5 * h);  // (read up to the core's depth)
      tbb::parallel_for(tbb::blocked_range<size_t>(0, cn), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t ci = r.begin(); ci < r.end(); ++ci)
          to_core[ci] = depth[ci] > 0 && std::sqrt(double(depth[ci])) - 0.5 * h >= thin_r
                            ? 0.0f
                            : std::numeric_limits<float>::infinity();
      });
      squared_distance_transform(cgrid, to_core, 2.0 * thin_r);
      // (Each crop voxel is its own voxel of the volume: the parallel writes never meet.)
      out.protected_voxels += tbb::parallel_reduce(
          tbb::blocked_range<size_t>(0, cn), uint64_t(0),
          [&](const tbb::blocked_range<size_t>& r, uint64_t count) {
            for (size_t ci = r.begin(); ci < r.end(); ++ci)
              if (depth[ci] > 0 && !(std::sqrt(double(to_core[ci])) <= 2.0 * thin_r)) {
                protected_distance[full_index(ci)] = 0;
                ++count;
              }
            return count;
          },
          std::plus<>());
    }
    // (Read as 0 or not by the junction shares; the flow's fade is 1 beyond tighten_r + 2h.)
    squared_distance_transform(grid, protected_distance, tighten_r + 2 * h);
  }
  const JunctionAngles angles =
      options.junction_correction > 0 && !junction_corners.empty()
          ? junction_angles(corner_shares(grid, labels, junction_corners, protected_distance), junction_corner_labels,
                            options.junction_correction * h)
          : JunctionAngles{};
  // How far from 0 every field must stay at a voxel centre, with the voxel's sign: island_margin at thin islands'
  // voxels (docs/design.md, "Small islands"), a sign only elsewhere.
  const HostArray<uint8_t> island =
      options.island_margin > 0 ? thin_islands(grid, labels, protected_distance, options.island_voxels) : HostArray<uint8_t>{};
  const float keep_anywhere = float(1e-3 * h), keep_island = float(std::max(1e-3, options.island_margin) * h);
  const auto keep = [&](size_t v) -> float { return !island.empty() && island[v] ? keep_island : keep_anywhere; };
  // Where the flow is allowed, in [0, 1]: away from junctions and protected thin parts.
  auto tighten_weight = [&](size_t v) {
    double w = 1;
    if (!junction_distance.empty()) w *= smoothstep01(std::sqrt(double(junction_distance[v])) / fade);
    if (!protected_distance.empty()) w *= smoothstep01((std::sqrt(double(protected_distance[v])) - h) / (tighten_r + h));
    return w;
  };
  for (const auto& [label, info] : found) {
    const auto& [count, box] = info;
    out.labels.push_back(label);
    out.voxel_counts.push_back(count);
    BrickField field(grid, -band);

    // The crop: the label's bounding box plus what the band, the smoothing and the tightening can reach.
    const Box crop = crop_of(box);
    const glm::ivec3 n = crop.size();
    Grid cgrid{n, grid.spacing, grid.origin};
    const size_t cn = cgrid.voxel_count();
    auto full_index = [&](size_t ci) {  // crop voxel -> the volume's voxel index
      const glm::ivec3 v = crop.lo + cgrid.voxel(ci);
      return grid.index(v.x, v.y, v.z);
    };
    constexpr float inf = std::numeric_limits<float>::infinity();
    HostArray<float> to_inside(cn), to_outside(cn);
    HostArray<uint8_t> inside(cn);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, cn), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t ci = r.begin(); ci < r.end(); ++ci) {
        inside[ci] = labels[full_index(ci)] == label;
        to_inside[ci] = inside[ci] ? 0.0f : inf;
        to_outside[ci] = inside[ci] ? inf : 0.0f;
      }
    });
    squared_distance_transform(cgrid, to_inside, double(band) + 0.5 * h);  // (clamped at the band below)
    squared_distance_transform(cgrid, to_outside, double(band) + 0.5 * h);
    // Signed distance to the mask boundary, which lies half a voxel beyond the boundary voxels' centres.
    HostArray<float>& phi = to_inside;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, cn), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t ci = r.begin(); ci < r.end(); ++ci) {
        const double d = inside[ci] ? std::sqrt(double(to_outside[ci])) - 0.5 * h : -(std::sqrt(double(phi[ci])) - 0.5 * h);
        phi[ci] = float(std::clamp(d, -double(band), double(band)));
      }
    });
    HostArray<float>().swap(to_outside);  // (freed: "= {}" would keep its capacity)
    // Constrained smoothing: no voxel centre changes side. Near junctions the plain Gaussian gives way to Tukey's
    // twicing of a narrower one, 2 G_j f - G_j G_j f: it removes the staircase as well, but rounds the wedge-shaped
    // edges of materials far less (at a kink, 0.33 voxel at sigma_j = 0.7 against 0.8 for sigma = 1), and it is that
    // rounding, unequal between a material's 90-degree edge and its neighbour's flat side, that moves triple curves.
    const bool twice = !junction_distance.empty() && options.junction_sigma > 0;
    HostArray<float> narrow, narrow2;
    auto blur = [&](std::span<float> f, double sigma) {
      for (int axis = 0; axis < 3; ++axis) gaussian_pass(f, n, axis, sigma / grid.spacing[axis]);
    };
    for (int it = 0; it < options.smoothing_iterations; ++it) {
      if (twice) {
        copy_into(narrow, phi);
        blur(narrow, options.junction_sigma * h);
        copy_into(narrow2, narrow);
        blur(narrow2, options.junction_sigma * h);
      }
      blur(phi, sigma_phys);
      tbb::parallel_for(tbb::blocked_range<size_t>(0, cn), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t ci = r.begin(); ci < r.end(); ++ci) {
          if (twice) {
            const double w = smoothstep01(std::sqrt(double(junction_distance[full_index(ci)])) / fade);
            phi[ci] = float(w * phi[ci] + (1 - w) * (2.0 * narrow[ci] - narrow2[ci]));
          }
          const float k = keep(full_index(ci));
          phi[ci] = inside[ci] ? std::max(phi[ci], k) : std::min(phi[ci], -k);
        }
      });
    }

    // Shrinkage correction: a Gaussian of variance s^2 moves the zero set of a signed distance field by
    // (s^2 / 2) * its Laplacian, i.e. by s^2 * (mean curvature) towards the convex side (a ball of radius R at
    // 48^3, R = 18.75 voxels, came out 0.107 voxel small after two rounds at sigma = 1: s^2 / R). Subtracting
    // (s^2 / 2) * Laplacian undoes it; the Laplacian is smoothed first (curvature_sigma) so the staircase is not
    // sharpened back. Near junctions the twicing is already corrected to this order and the term fades out.
    if (options.curvature_correction && sigma_phys > 0) {
      HostArray<float> lap = filled(cn, 0.0f);
      const double ix2 = 1 / (grid.spacing.x * grid.spacing.x), iy2 = 1 / (grid.spacing.y * grid.spacing.y),
                   iz2 = 1 / (grid.spacing.z * grid.spacing.z);
      const size_t sy = size_t(n.x), sz = size_t(n.x) * size_t(n.y);
      tbb::parallel_for(tbb::blocked_range<int>(1, std::max(1, n.z - 1)), [&](const tbb::blocked_range<int>& r) {
        for (int k = r.begin(); k < r.end(); ++k)
          for (int j = 1; j + 1 < n.y; ++j)
            for (int i = 1; i + 1 < n.x; ++i) {
              const size_t ci = size_t(k) * sz + size_t(j) * sy + size_t(i);
              const double c = 2.0 * phi[ci];
              lap[ci] = float((phi[ci + 1] + phi[ci - 1] - c) * ix2 + (phi[ci + sy] + phi[ci - sy] - c) * iy2 +
                              (phi[ci + sz] + phi[ci - sz] - c) * iz2);
            }
      });
      blur(lap, options.curvature_sigma * h);
      const double variance = double(options.smoothing_iterations) * sigma_phys * sigma_phys;
      tbb::parallel_for(tbb::blocked_range<size_t>(0, cn), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t ci = r.begin(); ci < r.end(); ++ci) {
          const double w = twice ? smoothstep01(std::sqrt(double(junction_distance[full_index(ci)])) / fade) : 1.0;
          const double v = std::clamp(phi[ci] - 0.5 * variance * w * lap[ci], -double(band), double(band));
          const double k = keep(full_index(ci));
          phi[ci] = float(inside[ci] ? std::max(v, k) : std::min(v, -k));
        }
      });
    }

    uint64_t moved = 0;
    if (tighten_r > 0) {
      const int iterations = options.tighten_iterations > 0 ? options.tighten_iterations
                                                            : 10 + int(std::ceil(10.0 * options.tighten_radius));
      tighten_field(phi, n, grid.spacing, tighten_r, iterations, double(band),
                    [&](size_t ci) { return tighten_weight(full_index(ci)); });
      moved = tbb::parallel_reduce(
          tbb::blocked_range<size_t>(0, cn), uint64_t(0),
          [&](const tbb::blocked_range<size_t>& r, uint64_t count) {
            for (size_t ci = r.begin(); ci < r.end(); ++ci) count += bool(inside[ci]) != (phi[ci] > 0);
            return count;
          },
          std::plus<>());
    }
    out.tightened_voxels.push_back(moved);

    // Into bricks: allocate those where the field is not a constant +-band.
    // Classified in parallel, allocated in brick order (the same data layout as one loop), then filled in parallel.
    const glm::ivec3 blo = crop.lo / BrickField::kBrick, bhi = crop.hi / BrickField::kBrick;
    const glm::ivec3 nb = bhi - blo + 1;
    auto brick_of = [&](size_t q) {
      return blo + glm::ivec3(int(q % size_t(nb.x)), int((q / size_t(nb.x)) % size_t(nb.y)), int(q / (size_t(nb.x) * size_t(nb.y))));
    };
    auto phi_at = [&](int i, int j, int k, bool* in_crop) {
      const glm::ivec3 c = glm::ivec3(i, j, k) - crop.lo;
      *in_crop = !glm::any(glm::lessThan(c, glm::ivec3(0))) && !glm::any(glm::greaterThanEqual(c, n));
      return *in_crop ? phi[(size_t(c.z) * size_t(n.y) + size_t(c.y)) * size_t(n.x) + size_t(c.x)] : -band;
    };
    enum BrickKind : uint8_t { kOutside, kInside, kVaries };
    std::vector<uint8_t> kind(size_t(nb.x) * size_t(nb.y) * size_t(nb.z));
    tbb::parallel_for(tbb::blocked_range<size_t>(0, kind.size()), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t q = r.begin(); q < r.end(); ++q) {
        const glm::ivec3 v0 = brick_of(q) * BrickField::kBrick, v1 = glm::min(v0 + BrickField::kBrick, grid.dims) - 1;
        bool varies = false, all_inside = true;
        for (int k = v0.z; k <= v1.z; ++k)
          for (int j = v0.y; j <= v1.y; ++j)
            for (int i = v0.x; i <= v1.x; ++i) {
              bool in_crop;
              const float v = phi_at(i, j, k, &in_crop);
              if (!in_crop) {
                all_inside = false;  // beyond the crop: far outside the material
                continue;
              }
              if (std::fabs(v) < band) varies = true;
              if (v < 0) all_inside = false;
            }
        kind[q] = varies ? kVaries : all_inside ? kInside : kOutside;
      }
    });
    for (size_t q = 0; q < kind.size(); ++q) {
      if (kind[q] == kVaries)
        field.allocate(brick_of(q));
      else
        field.set_brick_constant(brick_of(q), kind[q] == kInside ? band : -band);
    }
    tbb::parallel_for(tbb::blocked_range<size_t>(0, kind.size()), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t q = r.begin(); q < r.end(); ++q) {
        if (kind[q] != kVaries) continue;
        const glm::ivec3 v0 = brick_of(q) * BrickField::kBrick, v1 = glm::min(v0 + BrickField::kBrick, grid.dims) - 1;
        for (int k = v0.z; k <= v1.z; ++k)
          for (int j = v0.y; j <= v1.y; ++j)
            for (int i = v0.x; i <= v1.x; ++i) {
              bool in_crop;
              field.set(i, j, k, phi_at(i, j, k, &in_crop));
            }
      }
    });
    // The wedge-angle offset goes into the field itself, so interfaces, curves, points and the partition all move
    // together. The offsets are kept for the sizing field (sizing_field.h).
    if (!angles.corners.empty())
      out.junction_offsets.push_back(
          add_junction_offset(label, field, band, keep, junction_corners, angles, junction_distance, grid, fade));
    out.fields.push_back(std::move(field));
  }
  index_materials_near(out);
  return out;
}

}  // namespace cpmesh::fields
