#include "mesh/well_composed.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "mesh/small_labels.h"

namespace cpmesh::mesh {
namespace {

// The label map with its strides, and what may change.
struct Labels {
  io::LabelVolume& v;
  std::array<int64_t, 3> stride;
  std::vector<uint8_t> changed;  // per voxel: changed once already
  std::vector<int64_t> census;   // voxels per label value
  std::vector<int64_t> budget;   // per label value: the most voxels it may gain, and the most it may lose
  std::vector<int64_t> gained, lost;
  int64_t protected_voxels;

  Labels(io::LabelVolume& volume, int64_t protect, double share)
      : v(volume), stride{1, volume.dims[0], volume.dims[0] * volume.dims[1]}, changed(volume.labels.size(), 0),
        census(label_census(volume)), budget(65536, 0), gained(65536, 0), lost(65536, 0), protected_voxels(protect) {
    for (size_t l = 0; l < census.size(); ++l) budget[l] = int64_t(std::ceil(share * double(census[l])));
  }
  uint16_t at(int64_t i) const { return v.labels[size_t(i)]; }
  std::array<int64_t, 3> coords(int64_t i) const {
    return {i % v.dims[0], i / stride[1] % v.dims[1], i / stride[2]};
  }

  // Voxels of label l among the face neighbours of voxel i.
  int face_neighbours(int64_t i, uint16_t l) const {
    const auto c = coords(i);
    int n = 0;
    for (int a = 0; a < 3; ++a) {
      if (c[a] > 0) n += at(i - stride[a]) == l;
      if (c[a] + 1 < v.dims[a]) n += at(i + stride[a]) == l;
    }
    return n;
  }

  // Voxels of label l in the 4 x 4 x 4 box whose lowest corner is one voxel below voxel i (clipped to the volume).
  int box_count(int64_t i, uint16_t l) const {
    const auto c = coords(i);
    std::array<int64_t, 3> lo, hi;
    for (int a = 0; a < 3; ++a) lo[a] = std::max<int64_t>(c[a] - 1, 0), hi[a] = std::min<int64_t>(c[a] + 3, v.dims[a]);
    int n = 0;
    for (int64_t z = lo[2]; z < hi[2]; ++z)
      for (int64_t y = lo[1]; y < hi[1]; ++y)
        for (int64_t x = lo[0]; x < hi[0]; ++x) n += at(x + y * stride[1] + z * stride[2]) == l;
    return n;
  }

  bool may_give(int64_t i) const {
    const uint16_t l = at(i);
    return !changed[size_t(i)] && census[l] >= protected_voxels && lost[l] < budget[l] && face_neighbours(i, l) > 0;
  }

  // One of `candidates` becomes label l: the one whose label is most common around `corner` (ties: the one with
  // more face neighbours of l, then the first). False when none may give.
  template <size_t N>
  bool join(uint16_t l, const std::array<int64_t, N>& candidates, int64_t corner) {
    if (gained[l] >= budget[l]) return false;
    int64_t best = -1;
    std::pair<int, int> best_score{-1, -1};
    for (int64_t x : candidates) {
      if (!may_give(x)) continue;
      const std::pair<int, int> score{box_count(corner, at(x)), face_neighbours(x, l)};
      if (score > best_score) best = x, best_score = score;
    }
    if (best < 0) return false;
    const uint16_t from = at(best);
    --census[from], ++census[l];
    ++lost[from], ++gained[l];
    v.labels[size_t(best)] = l;
    changed[size_t(best)] = 1;
    return true;
  }
};

// The 2 x 2 squares at voxel i: in the planes of axes (0, 1), (0, 2) and (1, 2), where they fit.
template <typename F>
void for_each_square(const io::LabelVolume& v, const std::array<int64_t, 3>& stride, F&& f) {
  const auto& d = v.dims;
  for (int64_t z = 0; z < d[2]; ++z)
    for (int64_t y = 0; y < d[1]; ++y)
      for (int64_t x = 0; x < d[0]; ++x) {
        const int64_t i = x + y * stride[1] + z * stride[2];
        const bool fits[3] = {x + 1 < d[0], y + 1 < d[1], z + 1 < d[2]};
        for (int u = 0; u < 3; ++u)
          for (int w = u + 1; w < 3; ++w)
            if (fits[u] && fits[w]) f(i, i + stride[u], i + stride[w], i + stride[u] + stride[w]);
      }
}

// The 2 x 2 x 2 cubes at voxel i: their eight voxels, bit a of the index stepping along axis a.
template <typename F>
void for_each_cube(const io::LabelVolume& v, const std::array<int64_t, 3>& stride, F&& f) {
  const auto& d = v.dims;
  for (int64_t z = 0; z + 1 < d[2]; ++z)
    for (int64_t y = 0; y + 1 < d[1]; ++y)
      for (int64_t x = 0; x + 1 < d[0]; ++x) {
        std::array<int64_t, 8> c;
        for (int b = 0; b < 8; ++b) c[size_t(b)] = x + (b & 1) + (y + (b >> 1 & 1)) * stride[1] + (z + (b >> 2)) * stride[2];
        f(c);
      }
}

// Squares (a, b, c, d): a and d on one diagonal, b and c on the other.
bool edge_only(const io::LabelVolume& v, int64_t p, int64_t q, int64_t r, int64_t s) {
  const auto& L = v.labels;
  return L[size_t(p)] == L[size_t(q)] && L[size_t(r)] != L[size_t(p)] && L[size_t(s)] != L[size_t(p)];
}

// Cube diagonal (k, 7 - k) with the six other voxels of other labels.
bool corner_only(const io::LabelVolume& v, const std::array<int64_t, 8>& c, int k) {
  const uint16_t l = v.labels[size_t(c[size_t(k)])];
  if (v.labels[size_t(c[size_t(7 - k)])] != l) return false;
  for (int b = 0; b < 8; ++b)
    if (b != k && b != 7 - k && v.labels[size_t(c[size_t(b)])] == l) return false;
  return true;
}

// One pass over the squares and cubes; returns the voxels changed.
int64_t repair_pass(Labels& s) {
  const io::LabelVolume& v = s.v;
  int64_t changed = 0;
  for_each_square(v, s.stride, [&](int64_t a, int64_t b, int64_t c, int64_t d) {
    const bool ad = edge_only(v, a, d, b, c), bc = edge_only(v, b, c, a, d);
    if (!ad && !bc) return;
    bool join_ad = ad;
    if (ad && bc) {
      const int na = s.box_count(a, s.at(a)), nb = s.box_count(a, s.at(b));
      join_ad = na != nb ? na < nb : s.at(a) < s.at(b);
    }
    if (join_ad) changed += s.join(s.at(a), std::array<int64_t, 2>{b, c}, a);
    else changed += s.join(s.at(b), std::array<int64_t, 2>{a, d}, a);
  });
  for_each_cube(v, s.stride, [&](const std::array<int64_t, 8>& c) {
    for (int k = 0; k < 4; ++k) {
      if (!corner_only(v, c, k)) continue;
      std::array<int64_t, 6> others;
      size_t n = 0;
      for (int b = 0; b < 8; ++b)
        if (b != k && b != 7 - k) others[n++] = c[size_t(b)];
      changed += s.join(s.at(c[size_t(k)]), others, c[0]);
      return;
    }
  });
  return changed;
}

}  // namespace

int64_t critical_configurations(const io::LabelVolume& v) {
  const std::array<int64_t, 3> stride{1, v.dims[0], v.dims[0] * v.dims[1]};
  int64_t n = 0;
  for_each_square(v, stride, [&](int64_t a, int64_t b, int64_t c, int64_t d) {
    n += edge_only(v, a, d, b, c);
    n += edge_only(v, b, c, a, d);
  });
  for_each_cube(v, stride, [&](const std::array<int64_t, 8>& c) {
    for (int k = 0; k < 4; ++k) n += corner_only(v, c, k);
  });
  return n;
}

WellComposedReport make_well_composed(io::LabelVolume& volume, int64_t protected_voxels, double change_share) {
  WellComposedReport rep;
  rep.applied = true;
  rep.critical_before = critical_configurations(volume);
  if (rep.critical_before == 0) return rep;
  Labels s(volume, protected_voxels, change_share);
  // Each pass changes voxels that never change again, so the passes end; a handful suffice in practice (a change
  // can leave a new edge-only pair beside it, as the corner-only pairs do by design).
  for (int64_t changed = 1; changed > 0 && rep.passes < 16; ++rep.passes) {
    changed = repair_pass(s);
    rep.voxels_changed += changed;
  }
  rep.critical_left = critical_configurations(volume);
  for (size_t l = 0; l < s.census.size(); ++l)
    if (s.gained[l] > 0 || s.lost[l] > 0) rep.labels.push_back({uint16_t(l), s.gained[l], s.lost[l]});
  return rep;
}

}  // namespace cpmesh::mesh
