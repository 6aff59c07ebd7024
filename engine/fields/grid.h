#pragma once
// The voxel grid that fields, the closest point embedding and the particles share.
//
// Coordinates: "local" physical coordinates put voxel (i, j, k)'s centre at (i, j, k) * spacing, i.e. the volume's
// origin is subtracted. Everything inside the pipeline (fields, closest points, particles) works in local coordinates,
// which keeps float32 precise near the volume; outputs add the origin back.
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::fields {

// A 64-bit key of an integer cell of any uniform grid (21 bits per axis, two's complement, so cells within 2^20 of
// the origin either way are distinct), for hashed buckets of points.
inline uint64_t cell_key(const glm::ivec3& c) {
  return (uint64_t(uint32_t(c.x) & 0x1fffff) << 42) | (uint64_t(uint32_t(c.y) & 0x1fffff) << 21) |
         uint64_t(uint32_t(c.z) & 0x1fffff);
}

// Points in hashed cubic buckets of one width: every point within that width of x lies in the 27 buckets around x's,
// so a neighbour query costs 27 lookups however far the points spread.
class PointBuckets {
 public:
  PointBuckets() = default;
  // position_of(i) for i in [0, count) gives point i.
  template <class PositionOf>
  PointBuckets(size_t count, PositionOf&& position_of, double width) : width_(width) {
    for (size_t i = 0; i < count; ++i) buckets_[key(position_of(i))].push_back(uint32_t(i));
  }
  // Calls visit(i) for every point i in the 27 buckets around x: a superset of the points within width of x.
  template <class Visit>
  void for_each_candidate(const glm::dvec3& x, Visit&& visit) const {
    for_each_candidate(x, width_, visit);
  }
  // The same, skipping the buckets farther than radius (<= width) from x: a superset of the points within radius,
  // visited in the same order.
  template <class Visit>
  void for_each_candidate(const glm::dvec3& x, double radius, Visit&& visit) const {
    const glm::ivec3 home(glm::floor(x / width_));
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const glm::ivec3 cell = home + glm::ivec3(dx, dy, dz);
          const glm::dvec3 lo = glm::dvec3(cell) * width_, outside = glm::max(glm::max(lo - x, x - (lo + width_)), 0.0);
          if (glm::dot(outside, outside) > radius * radius * (1.0 + 1e-12)) continue;  // (rounding: keep ties)
          const auto it = buckets_.find(cell_key(cell));
          if (it == buckets_.end()) continue;
          for (uint32_t i : it->second) visit(i);
        }
  }

 private:
  uint64_t key(const glm::dvec3& x) const { return cell_key(glm::ivec3(glm::floor(x / width_))); }
  double width_ = 1.0;
  std::unordered_map<uint64_t, std::vector<uint32_t>> buckets_;
};

struct Grid {
  glm::ivec3 dims{0};
  glm::dvec3 spacing{1.0};
  glm::dvec3 origin{0.0};  // physical position of voxel (0, 0, 0)'s centre

  size_t voxel_count() const { return size_t(dims.x) * size_t(dims.y) * size_t(dims.z); }
  size_t index(int i, int j, int k) const { return (size_t(k) * size_t(dims.y) + size_t(j)) * size_t(dims.x) + size_t(i); }
  glm::ivec3 voxel(size_t index) const {  // the inverse of index()
    const size_t nx = size_t(dims.x), ny = size_t(dims.y);
    return glm::ivec3(int(index % nx), int((index / nx) % ny), int(index / (nx * ny)));
  }
  bool inside(int i, int j, int k) const {
    return i >= 0 && j >= 0 && k >= 0 && i < dims.x && j < dims.y && k < dims.z;
  }
  glm::dvec3 local(const glm::dvec3& ijk) const { return ijk * spacing; }      // voxel index space -> local
  glm::dvec3 to_index(const glm::dvec3& local_pos) const { return local_pos / spacing; }
  glm::dvec3 to_physical(const glm::dvec3& local_pos) const { return local_pos + origin; }
  double min_spacing() const { return std::min(spacing.x, std::min(spacing.y, spacing.z)); }

  // The distinct labels among the 8 voxels around the grid corner between voxel (i, j, k) and (i+1, j+1, k+1) (the
  // dual cell where interfaces, curves and points meet), in order of first appearance; returns how many.
  // label_of(voxel index) gives a voxel's label. Needs i + 1, j + 1, k + 1 inside the grid.
  template <class LabelOf>
  int corner_labels(int i, int j, int k, LabelOf&& label_of, uint16_t out[8]) const {
    int n = 0;
    for (int c = 0; c < 8; ++c) {
      const uint16_t l = uint16_t(label_of(index(i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2))));
      bool seen = false;
      for (int a = 0; a < n; ++a) seen = seen || out[a] == l;
      if (!seen) out[n++] = l;
    }
    return n;
  }
};

}  // namespace cpmesh::fields
