#pragma once
// A scalar field on the voxel grid stored sparsely: bricks of 8^3 voxels hold values only where the field varies
// (the narrow band around an interface); every other brick is one constant. Memory grows with the interface area.
#include <cstdint>
#include <vector>

#include "fields/grid.h"

namespace cpmesh::fields {

class BrickField {
 public:
  static constexpr int kBrick = 8;
  static constexpr int kBrickVoxels = kBrick * kBrick * kBrick;

  BrickField() = default;
  BrickField(const Grid& grid, float background);

  const Grid& grid() const { return grid_; }
  glm::ivec3 brick_dims() const { return brick_dims_; }
  size_t allocated_bricks() const { return data_.size() / kBrickVoxels; }
  size_t memory_bytes() const;

  // Value at a voxel; outside the grid the nearest voxel's value (clamp to edge).
  float at(int i, int j, int k) const;
  // Sets a voxel, allocating its brick (filled with the brick's constant) when needed. Not thread-safe across bricks
  // being allocated; use allocate() first for parallel writes.
  void set(int i, int j, int k, float value);
  void set_brick_constant(const glm::ivec3& brick, float value);
  void allocate(const glm::ivec3& brick);
  // Index of a brick (x fastest): what allocated, brick_values and brick_constant look up.
  size_t brick_index(const glm::ivec3& b) const {
    return (size_t(b.z) * size_t(brick_dims_.y) + size_t(b.y)) * size_t(brick_dims_.x) + size_t(b.x);
  }
  bool allocated(const glm::ivec3& brick) const { return slot_[brick_index(brick)] >= 0; }
  float* brick_data(const glm::ivec3& brick);  // null when the brick is constant
  const float* brick_values(const glm::ivec3& brick) const {  // the same, read-only
    const int32_t s = slot_[brick_index(brick)];
    return s < 0 ? nullptr : data_.data() + size_t(s) * kBrickVoxels;
  }
  float brick_constant(const glm::ivec3& brick) const { return constant_[brick_index(brick)]; }

  // Catmull-Rom tricubic interpolation at a continuous voxel-index position (voxel centres at integers): C1, passes
  // through the samples. `gradient` (optional) receives d/d(index).
  double sample_cubic(const glm::dvec3& ijk, glm::dvec3* gradient = nullptr) const;
  double sample_linear(const glm::dvec3& ijk) const;
  // sample_cubic at a point in local coordinates (fields/grid.h), with the gradient in local coordinates too.
  double sample_cubic_local(const glm::dvec3& local, glm::dvec3* gradient = nullptr) const {
    glm::dvec3 g;
    const double v = sample_cubic(local / grid_.spacing, gradient ? &g : nullptr);
    if (gradient) *gradient = g / grid_.spacing;
    return v;
  }
  // sample_cubic of several fields on the same grid at one point, sharing the weights and the gather's indexing (the
  // Newton projections evaluate two to four fields at every step).
  static void sample_cubic_many(const BrickField* const* fields, int count, const glm::dvec3& ijk, double* values,
                                glm::dvec3* gradients);
  // sample_linear of several fields on the same grid at one point (the same values), the corners' bricks and offsets
  // found once for all of them (IndicatorFields::material_at: every field at every tet of the Delaunay mesh).
  static void sample_linear_many(const BrickField* const* fields, int count, const glm::dvec3& ijk, double* values);

 private:
  Grid grid_;
  glm::ivec3 brick_dims_{0};
  std::vector<int32_t> slot_;     // per brick: index of its data block, or -1 when constant
  std::vector<float> constant_;   // per brick: its value when constant
  std::vector<float> data_;       // allocated bricks, kBrickVoxels each, x fastest
};

}  // namespace cpmesh::fields
