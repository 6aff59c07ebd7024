#include "io/synth_corpus.h"

#include <algorithm>
#include <atomic>
#include <limits>
#include <cmath>
#include <functional>
#include <numeric>

#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include "io/error.h"

namespace cpmesh::io {

namespace {

// Everything here is laid out in voxel-index coordinates: a sheet "one voxel thick" is one voxel thick in the image
// whatever the spacing, as in a real anisotropic scan.
using Vec = std::array<double, 3>;

uint64_t mix(uint64_t x) {  // splitmix64's finaliser
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}
double unit(uint64_t h) { return double(h >> 11) * 0x1.0p-53; }  // [0, 1)
double hash01(uint64_t seed, int64_t i, int64_t j, int64_t k) {
  return unit(mix(seed ^ mix(uint64_t(i) * 0x100000001b3ull ^ mix(uint64_t(j) ^ mix(uint64_t(k))))));
}

struct Rng {
  uint64_t state;
  double uniform(double a = 0, double b = 1) { return a + (b - a) * unit(mix(state++)); }
  int64_t below(int64_t n) { return std::min<int64_t>(n - 1, int64_t(uniform() * double(n))); }
};

// Smooth value noise in [-1, 1]: hashed lattice values, blended with smoothstep weights.
double value_noise(const Vec& p, uint64_t seed) {
  const double fx = std::floor(p[0]), fy = std::floor(p[1]), fz = std::floor(p[2]);
  auto s = [](double t) { return t * t * (3 - 2 * t); };
  const double u = s(p[0] - fx), v = s(p[1] - fy), w = s(p[2] - fz);
  const auto i = int64_t(fx), j = int64_t(fy), k = int64_t(fz);
  double sum = 0;
  for (int c = 0; c < 8; ++c) {
    const int a = c & 1, b = (c >> 1) & 1, d = c >> 2;
    const double weight = (a ? u : 1 - u) * (b ? v : 1 - v) * (d ? w : 1 - w);
    sum += weight * (2 * hash01(seed, i + a, j + b, k + d) - 1);
  }
  return sum;
}

Vec warp(const Vec& q, double period, double amplitude, uint64_t seed) {
  const Vec p = {q[0] / period, q[1] / period, q[2] / period};
  return {q[0] + amplitude * value_noise(p, seed), q[1] + amplitude * value_noise(p, seed + 101),
          q[2] + amplitude * value_noise(p, seed + 202)};
}

double norm(const Vec& a) { return std::hypot(a[0], a[1], a[2]); }
Vec sub(const Vec& a, const Vec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double ellipsoid_radius(const Vec& q, const Vec& c, const Vec& semi) {  // 1 on the surface
  return std::hypot((q[0] - c[0]) / semi[0], (q[1] - c[1]) / semi[1], (q[2] - c[2]) / semi[2]);
}
// Distance from q to the line through a along the unit direction d.
double line_distance(const Vec& q, const Vec& a, const Vec& d) {
  const Vec r = sub(q, a);
  const double t = r[0] * d[0] + r[1] * d[1] + r[2] * d[2];
  return norm({r[0] - t * d[0], r[1] - t * d[1], r[2] - t * d[2]});
}
Vec unit_vector(const Vec& a) {
  const double n = norm(a);
  return {a[0] / n, a[1] / n, a[2] / n};
}

void fill(LabelVolume& v, const std::function<uint16_t(const Vec&)>& label) {
  tbb::parallel_for(int64_t(0), v.dims[2], [&](int64_t k) {
    for (int64_t j = 0; j < v.dims[1]; ++j)
      for (int64_t i = 0; i < v.dims[0]; ++i) v.labels[v.index(i, j, k)] = label({double(i), double(j), double(k)});
  });
}

Vec extent(const LabelVolume& v) { return {double(v.dims[0]), double(v.dims[1]), double(v.dims[2])}; }
Vec at(const Vec& D, double fx, double fy, double fz) { return {fx * D[0], fy * D[1], fz * D[2]}; }

// Boxes of `size` voxels set to `label` where the box and a margin of `margin` voxels around it hold only `inside`;
// up to `attempts` random places each. Returns the boxes placed.
int place_boxes(LabelVolume& v, Rng& rng, const std::vector<std::array<int64_t, 3>>& sizes, uint16_t inside, uint16_t label,
                int64_t margin, int attempts = 400) {
  int placed = 0;
  for (const auto& s : sizes) {
    for (int a = 0; a < attempts; ++a) {
      std::array<int64_t, 3> lo{};
      for (int c = 0; c < 3; ++c) lo[size_t(c)] = margin + rng.below(std::max<int64_t>(1, v.dims[size_t(c)] - s[size_t(c)] - 2 * margin));
      bool ok = true;
      for (int64_t k = lo[2] - margin; ok && k < lo[2] + s[2] + margin; ++k)
        for (int64_t j = lo[1] - margin; ok && j < lo[1] + s[1] + margin; ++j)
          for (int64_t i = lo[0] - margin; ok && i < lo[0] + s[0] + margin; ++i)
            ok = i >= 0 && j >= 0 && k >= 0 && i < v.dims[0] && j < v.dims[1] && k < v.dims[2] && v.labels[v.index(i, j, k)] == inside;
      if (!ok) continue;
      for (int64_t k = lo[2]; k < lo[2] + s[2]; ++k)
        for (int64_t j = lo[1]; j < lo[1] + s[1]; ++j)
          for (int64_t i = lo[0]; i < lo[0] + s[0]; ++i) v.labels[v.index(i, j, k)] = label;
      ++placed;
      break;
    }
  }
  return placed;
}

// Two face-adjacent voxels of `outside` set to `label`, the first of them face-adjacent to `beside`; scanned from the
// volume's centre outwards along +x rows so the place is deterministic. Returns whether it found one.
bool place_pair_beside(LabelVolume& v, uint16_t beside, uint16_t outside, uint16_t label) {
  auto get = [&](int64_t i, int64_t j, int64_t k) {
    return (i < 0 || j < 0 || k < 0 || i >= v.dims[0] || j >= v.dims[1] || k >= v.dims[2]) ? uint16_t(0xffff)
                                                                                             : v.labels[v.index(i, j, k)];
  };
  const int64_t k0 = v.dims[2] / 2;
  for (int64_t dk = 0; dk < v.dims[2]; ++dk) {
    const int64_t k = k0 + ((dk & 1) ? -(dk + 1) / 2 : dk / 2);
    for (int64_t j = 1; j + 1 < v.dims[1]; ++j)
      for (int64_t i = 1; i + 2 < v.dims[0]; ++i) {
        if (get(i, j, k) != outside || get(i + 1, j, k) != outside) continue;
        const bool touches = get(i - 1, j, k) == beside || get(i, j - 1, k) == beside || get(i, j + 1, k) == beside ||
                             get(i, j, k - 1) == beside || get(i, j, k + 1) == beside;
        if (!touches) continue;
        v.labels[v.index(i, j, k)] = label;
        v.labels[v.index(i + 1, j, k)] = label;
        return true;
      }
  }
  return false;
}

// Isolated flips: a voxel on a label boundary whose hash falls under `share` takes its first differing 6-neighbour's
// label (read from the unflipped labels, so the result does not depend on the order of the visit).
size_t flip_boundary_voxels(LabelVolume& v, double share, uint64_t seed) {
  if (share <= 0) return 0;
  const std::vector<uint16_t> before = v.labels;
  std::atomic<size_t> flips{0};
  tbb::parallel_for(int64_t(0), v.dims[2], [&](int64_t k) {
    size_t local = 0;
    for (int64_t j = 0; j < v.dims[1]; ++j)
      for (int64_t i = 0; i < v.dims[0]; ++i) {
        if (hash01(seed ^ 0x5eedull, i, j, k) >= share) continue;
        const uint16_t here = before[v.index(i, j, k)];
        const std::array<std::array<int64_t, 3>, 6> n = {{{i - 1, j, k}, {i + 1, j, k}, {i, j - 1, k}, {i, j + 1, k}, {i, j, k - 1}, {i, j, k + 1}}};
        for (const auto& q : n) {
          if (q[0] < 0 || q[1] < 0 || q[2] < 0 || q[0] >= v.dims[0] || q[1] >= v.dims[1] || q[2] >= v.dims[2]) continue;
          const uint16_t other = before[v.index(q[0], q[1], q[2])];
          if (other == here) continue;
          v.labels[v.index(i, j, k)] = other;
          ++local;
          break;
        }
      }
    flips += local;
  });
  return flips;
}

// The parcellation (see the header).
struct Parcellation {
  Vec centre, semi, stem;  // stem: x, y of its axis and its radius
  double bump_period;
  uint64_t seed;
  // > 1 outside, with bumps, and the stem below the centre down through the bottom face.
  bool in_mask(const Vec& q) const {
    const double bump = 0.06 * value_noise({q[0] / bump_period, q[1] / bump_period, q[2] / bump_period}, seed + 7);
    if (ellipsoid_radius(q, centre, semi) < 1 + bump) return true;
    return q[2] < centre[2] && std::hypot(q[0] - stem[0], q[1] - stem[1]) < stem[2];
  }
  double depth(const Vec& q) const { return ellipsoid_radius(q, centre, semi); }
};

struct SeedGrid {
  double cell;
  std::array<int64_t, 3> n;
  std::vector<std::vector<uint32_t>> cells;
  std::vector<Vec> seeds;
  std::vector<double> speed;
  std::array<int64_t, 3> cell_of(const Vec& q) const {
    std::array<int64_t, 3> c{};
    for (int a = 0; a < 3; ++a) c[size_t(a)] = std::clamp<int64_t>(int64_t(std::floor(q[size_t(a)] / cell)), 0, n[size_t(a)] - 1);
    return c;
  }
  // The seed with the smallest distance / speed among the 27 cells around q's (wider rings where those are empty).
  uint32_t nearest(const Vec& q) const {
    const auto c = cell_of(q);
    uint32_t best = 0;
    double best_score = std::numeric_limits<double>::infinity();
    for (int64_t r = 1; r <= std::max({n[0], n[1], n[2]}) && !std::isfinite(best_score); ++r)
      for (int64_t dz = -r; dz <= r; ++dz)
        for (int64_t dy = -r; dy <= r; ++dy)
          for (int64_t dx = -r; dx <= r; ++dx) {
            const int64_t x = c[0] + dx, y = c[1] + dy, z = c[2] + dz;
            if (x < 0 || y < 0 || z < 0 || x >= n[0] || y >= n[1] || z >= n[2]) continue;
            for (uint32_t s : cells[size_t((z * n[1] + y) * n[0] + x)]) {
              const double score = norm(sub(q, seeds[s])) / speed[s];
              if (score < best_score) best_score = score, best = s;
            }
          }
    return best;
  }
};

void make_parcellation(const SynthOptions& o, LabelVolume& v, nlohmann::json& params) {
  const Vec D = extent(v);
  const int labels = o.labels > 0 ? o.labels : 80;
  Parcellation p;
  p.centre = at(D, 0.5, 0.5, 0.56);
  p.centre[0] += 0.3, p.centre[1] -= 0.2, p.centre[2] += 0.15;
  p.semi = at(D, 0.41, 0.56, 0.36);  // cropped by the y faces, as a tight field of view is
  p.stem = {p.centre[0], p.centre[1] + 0.1 * D[1], std::max(2.5, 0.08 * D[0])};
  p.bump_period = 0.12 * D[0];
  p.seed = o.seed;
  Rng rng{mix(o.seed * 7919 + 17)};

  // Seeds: denser near the rim (small cortical parcels), sparser deep, each with its own speed.
  const int tiny = std::max(3, labels / 20);
  const int regular = labels - tiny;
  SeedGrid g;
  while (int(g.seeds.size()) < regular) {
    const Vec q = {rng.uniform(0, D[0]), rng.uniform(0, D[1]), rng.uniform(0, D[2])};
    if (!p.in_mask(q)) continue;
    const double accept = 0.25 + 0.75 * std::clamp(p.depth(q), 0.0, 1.0);
    if (rng.uniform() >= accept) continue;
    g.seeds.push_back(q);
    g.speed.push_back(rng.uniform(0.7, 1.4));
  }
  const double mask_volume = 4.0 / 3.0 * 3.14159 * p.semi[0] * std::min(p.semi[1], D[1] / 2) * p.semi[2];
  g.cell = std::max(2.0, 1.5 * std::cbrt(mask_volume / regular));
  for (int a = 0; a < 3; ++a) g.n[size_t(a)] = std::max<int64_t>(1, int64_t(std::ceil(D[size_t(a)] / g.cell)));
  g.cells.resize(size_t(g.n[0] * g.n[1] * g.n[2]));
  for (uint32_t s = 0; s < g.seeds.size(); ++s) {
    const auto c = g.cell_of(g.seeds[s]);
    g.cells[size_t((c[2] * g.n[1] + c[1]) * g.n[0] + c[0])].push_back(s);
  }

  // Ids without repetition from 1..max(1100, 4 labels): not contiguous, some above 1000.
  std::vector<uint16_t> ids(size_t(std::max(1100, 4 * labels)));
  std::iota(ids.begin(), ids.end(), uint16_t(1));
  for (size_t i = ids.size() - 1; i > 0; --i) std::swap(ids[i], ids[size_t(rng.below(int64_t(i + 1)))]);
  ids.resize(size_t(labels));

  const double warp_period = 7.0, warp_amplitude = 2.5;
  fill(v, [&](const Vec& q) -> uint16_t {
    if (!p.in_mask(q)) return 0;
    return ids[g.nearest(warp(q, warp_period, warp_amplitude, o.seed + 3))];
  });
  // Tiny parcels: balls of 20-60 voxels somewhere inside the mask, away from its rim.
  int tiny_placed = 0;
  for (int t = 0, tries = 0; t < tiny && tries < 10000; ++tries) {
    const Vec c = {rng.uniform(3, D[0] - 3), rng.uniform(3, D[1] - 3), rng.uniform(3, D[2] - 3)};
    if (!p.in_mask(c) || p.depth(c) > 0.85) continue;
    const double r = rng.uniform(1.6, 2.4);
    for (int64_t k = int64_t(c[2] - r) - 1; k <= int64_t(c[2] + r) + 1; ++k)
      for (int64_t j = int64_t(c[1] - r) - 1; j <= int64_t(c[1] + r) + 1; ++j)
        for (int64_t i = int64_t(c[0] - r) - 1; i <= int64_t(c[0] + r) + 1; ++i)
          if (i >= 0 && j >= 0 && k >= 0 && i < v.dims[0] && j < v.dims[1] && k < v.dims[2] &&
              norm(sub({double(i), double(j), double(k)}, c)) < r)
            v.labels[v.index(i, j, k)] = ids[size_t(regular + t)];
    ++t, ++tiny_placed;
  }
  params["labels"] = labels;
  params["tiny_parcels"] = tiny_placed;
  params["seed_cell"] = g.cell;
  params["warp"] = {{"period", warp_period}, {"amplitude", warp_amplitude}};
}

void make_thin(LabelVolume& v, nlohmann::json& params) {
  const Vec D = extent(v);
  const double m = std::min({D[0], D[1], D[2]});
  Vec c = at(D, 0.5, 0.5, 0.5);
  c[0] += 0.3, c[1] -= 0.2, c[2] += 0.15;
  const double R = 0.46 * m, skull = std::max(3.0, 0.07 * m);
  const Vec tube2_dir = unit_vector({0.7, 0.45, 0.55});
  const Vec tube2_at = at(D, 0.52, 0.47, 0.5);
  const Vec vessel_dir = unit_vector({0.08, 0.05, 1.0});
  const Vec vessel_at = {c[0] - 0.45 * R, c[1] - 0.2 * R, c[2]};
  params["radius"] = R;
  params["skull"] = skull;
  fill(v, [&](const Vec& q) -> uint16_t {
    if (line_distance(q, tube2_at, tube2_dir) < 1.05) return 60;  // two voxels across, through every layer
    const double d = norm(sub(q, c));
    if (d >= R) return 0;
    if (d >= R - skull) return 20;
    const double csf = q[0] < c[0] ? 1.0 : 2.0;  // one voxel on one side, two on the other
    if (d >= R - skull - csf) return 30;
    // A one-voxel tube along x, waving in z, that pierces the falx.
    if (std::hypot(q[1] - (c[1] + 0.25 * R), q[2] - (c[2] + 0.3 * R + 2.0 * std::sin(q[0] / 7.0))) < 0.6) return 50;
    // The falx: a one-voxel wavy sheet in the upper half, ending on the CSF above and inside the brain below.
    if (std::abs(q[0] - c[0] - 0.3 - 1.5 * std::sin(q[1] / 9.0)) < 0.5 && q[2] > c[2] - 0.1 * R) return 40;
    // A vessel in the lower half: lumen 80 and a one-voxel wall 70.
    if (q[2] < c[2] && d < R - skull - 3) {
      const double r = line_distance(q, vessel_at, vessel_dir);
      if (r < 1.6) return 80;
      if (r < 2.6) return 70;
    }
    return 10;
  });
}

void make_islands(const SynthOptions& o, LabelVolume& v, nlohmann::json& params) {
  const Vec D = extent(v);
  const double m = std::min({D[0], D[1], D[2]});
  const Vec c1 = at(D, 0.38, 0.5, 0.5), s1 = at(D, 0.27, 0.31, 0.29);
  const Vec c2 = at(D, 0.7, 0.52, 0.48);
  const double r2 = 0.2 * m;
  fill(v, [&](const Vec& q) -> uint16_t {
    if (norm(sub(q, c2)) < r2) return 2;
    if (ellipsoid_radius(warp(q, 6.0, 1.5, o.seed + 11), c1, s1) < 1) return 1;
    return 0;
  });
  Rng rng{mix(o.seed * 104729 + 5)};
  const std::vector<std::array<int64_t, 3>> sizes = {{1, 1, 1}, {2, 1, 1}, {2, 2, 1}, {2, 2, 2}, {4, 2, 2}, {3, 3, 3}, {4, 4, 4}};
  const int in1 = place_boxes(v, rng, sizes, 1, 3, 2);
  const int two_in1 = place_boxes(v, rng, {{1, 1, 1}, {2, 2, 2}, {3, 3, 3}}, 1, 2, 2);
  const int one_out = place_boxes(v, rng, {{1, 1, 1}, {2, 2, 1}, {4, 2, 2}, {4, 4, 4}}, 0, 1, 2);
  // Enclosed pockets of background inside 2: balls of radius 1.2, 2 and 2.8 voxels.
  int pockets = 0;
  const std::array<Vec, 3> offsets = {{{-0.55, 0, 0.1}, {0, 0, 0.1}, {0, 0.55, 0.1}}};  // apart by more than two radii
  for (double r : {1.2, 2.0, 2.8}) {
    const Vec& off = offsets[size_t(pockets)];
    const Vec p = {c2[0] + off[0] * r2, c2[1] + off[1] * r2, c2[2] + off[2] * r2};
    for (int64_t k = 0; k < v.dims[2]; ++k)
      for (int64_t j = 0; j < v.dims[1]; ++j)
        for (int64_t i = 0; i < v.dims[0]; ++i)
          if (norm(sub({double(i), double(j), double(k)}, p)) < r && v.labels[v.index(i, j, k)] == 2) v.labels[v.index(i, j, k)] = 0;
    ++pockets;
  }
  const bool pair = place_pair_beside(v, 1, 0, 5);
  params["islands"] = {{"label_3_in_1", in1}, {"label_2_in_1", two_in1}, {"label_1_in_0", one_out}};
  params["pockets"] = pockets;
  params["two_voxel_label"] = pair ? 5 : 0;
}

void make_organs(const SynthOptions& o, LabelVolume& v, nlohmann::json& params) {
  const Vec D = extent(v);
  const Vec c = {0.5 * D[0] + 0.3, 0.5 * D[1] - 0.2, 0.5 * D[2] + 0.15};
  const Vec liver = {c[0] - 0.2 * D[0], c[1] - 0.05 * D[1], c[2]}, liver_semi = at(D, 0.19, 0.22, 0.36);
  const Vec kidney_l = {c[0] - 0.15 * D[0], c[1] + 0.18 * D[1], c[2] - 0.05 * D[2]};
  const Vec kidney_r = {c[0] + 0.17 * D[0], c[1] + 0.18 * D[1], c[2] - 0.05 * D[2]};
  const Vec kidney_semi = at(D, 0.055, 0.075, 0.3);
  const Vec spleen = {c[0] + 0.22 * D[0], c[1] - 0.02 * D[1], c[2] + 0.1 * D[2]}, spleen_semi = at(D, 0.07, 0.09, 0.25);
  const Vec spine = {c[0], c[1] + 0.29 * D[1], 0};
  const double aorta_r = std::max(1.5, 0.004 * D[0]);
  fill(v, [&](const Vec& q) -> uint16_t {
    const double ripple = 0.02 * value_noise({q[0] / 9, q[1] / 9, q[2] / 9}, o.seed + 21);
    if (std::hypot((q[0] - c[0]) / (0.46 * D[0]), (q[1] - c[1]) / (0.42 * D[1])) >= 1 + ripple) return 0;
    const Vec w = warp(q, 0.05 * D[0] + 4, 1.0 + 0.004 * D[0], o.seed + 23);
    if (ellipsoid_radius(w, liver, liver_semi) < 1) return 6;  // overlaps the left kidney: they touch
    if (ellipsoid_radius(w, kidney_l, kidney_semi) < 1) return 2;
    if (ellipsoid_radius(w, kidney_r, kidney_semi) < 1) return 3;
    if (ellipsoid_radius(w, spleen, spleen_semi) < 1) return 4;
    if (std::hypot(q[0] - (c[0] + 0.04 * D[0]), q[1] - (c[1] + 0.16 * D[1])) < aorta_r) return 5;
    const double rs = std::hypot(q[0] - spine[0], q[1] - spine[1]);
    if (rs < 0.06 * D[0] && rs >= 0.025 * D[0]) return 7;  // the vertebrae around a canal of body
    return 1;
  });
  const bool pair = place_pair_beside(v, 6, 1, 9);
  params["two_voxel_label"] = pair ? 9 : 0;
  params["aorta_radius"] = aorta_r;
}

}  // namespace

bool is_corpus_shape(SynthShape s) {
  return s == SynthShape::parcellation || s == SynthShape::thin || s == SynthShape::islands || s == SynthShape::organs;
}

void make_corpus_volume(const SynthOptions& o, LabelVolume& v, std::string& description) {
  nlohmann::json params;
  params["shape"] = synth_shape_name(o.shape);
  params["seed"] = o.seed;
  switch (o.shape) {
    case SynthShape::parcellation: make_parcellation(o, v, params); break;
    case SynthShape::thin: make_thin(v, params); break;
    case SynthShape::islands: make_islands(o, v, params); break;
    case SynthShape::organs: make_organs(o, v, params); break;
    default: throw Error("field 'shape': not a corpus kind");
  }
  params["noise"] = o.noise;
  params["flipped_voxels"] = flip_boundary_voxels(v, o.noise, o.seed);
  description = params.dump();
}

const std::vector<CorpusEntry>& corpus() {
  static const std::vector<CorpusEntry> entries = [] {
    auto entry = [](std::string name, SynthShape shape, int64_t size, bool large, int labels = 0, double noise = 0,
                    std::array<double, 3> spacing = {1, 1, 1}) {
      CorpusEntry e{std::move(name), {}, large};
      e.options.shape = shape;
      e.options.size = size;
      e.options.labels = labels;
      e.options.noise = noise;
      e.options.spacing = spacing;
      return e;
    };
    const std::array<double, 3> ct = {0.62, 0.62, 1.33};
    return std::vector<CorpusEntry>{
        entry("parcellation-48", SynthShape::parcellation, 48, false, 40, 0.01),
        entry("thin-48", SynthShape::thin, 48, false),
        entry("islands-48", SynthShape::islands, 48, false),
        entry("organs-64", SynthShape::organs, 64, false, 0, 0.01, ct),
        entry("noisy-48", SynthShape::parcellation, 48, false, 12, 0.04, {0.6, 0.6, 1.3}),
        entry("parcellation-300", SynthShape::parcellation, 72, false, 300),
        // 304 parcels asked, 300 left in the mask at 32^3 (27 of them under 8 voxels): the CI's many-label volume.
        entry("parcellation-300-32", SynthShape::parcellation, 32, false, 304),
        entry("parcellation-50", SynthShape::parcellation, 100, true, 50, 0.01),
        entry("thin-128", SynthShape::thin, 128, true),
        entry("islands-128", SynthShape::islands, 128, true),
        entry("organs-438", SynthShape::organs, 438, true, 0, 0.005, ct),
        entry("parcellation-200", SynthShape::parcellation, 292, true, 200, 0.005),
    };
  }();
  return entries;
}

const CorpusEntry& corpus_entry(const std::string& name) {
  std::string known;
  for (const auto& e : corpus()) {
    if (e.name == name) return e;
    known += (known.empty() ? "" : ", ") + e.name;
  }
  throw Error("field 'corpus': expected one of " + known + ", got '" + name + "'");
}

}  // namespace cpmesh::io
