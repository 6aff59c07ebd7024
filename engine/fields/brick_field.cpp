#include "fields/brick_field.h"

#include <algorithm>
#include <cstring>

namespace cpmesh::fields {

BrickField::BrickField(const Grid& grid, float background) : grid_(grid) {
  brick_dims_ = (grid.dims + glm::ivec3(kBrick - 1)) / kBrick;
  const size_t n = size_t(brick_dims_.x) * size_t(brick_dims_.y) * size_t(brick_dims_.z);
  slot_.assign(n, -1);
  constant_.assign(n, background);
}

size_t BrickField::memory_bytes() const {
  return slot_.size() * sizeof(int32_t) + constant_.size() * sizeof(float) + data_.size() * sizeof(float);
}

float BrickField::at(int i, int j, int k) const {
  i = std::clamp(i, 0, grid_.dims.x - 1);
  j = std::clamp(j, 0, grid_.dims.y - 1);
  k = std::clamp(k, 0, grid_.dims.z - 1);
  const glm::ivec3 b(i / kBrick, j / kBrick, k / kBrick);
  const size_t bi = brick_index(b);
  const int32_t s = slot_[bi];
  if (s < 0) return constant_[bi];
  return data_[size_t(s) * kBrickVoxels + size_t(((k % kBrick) * kBrick + (j % kBrick)) * kBrick + (i % kBrick))];
}

void BrickField::allocate(const glm::ivec3& b) {
  const size_t bi = brick_index(b);
  if (slot_[bi] >= 0) return;
  slot_[bi] = int32_t(data_.size() / kBrickVoxels);
  data_.resize(data_.size() + kBrickVoxels, constant_[bi]);
}

float* BrickField::brick_data(const glm::ivec3& b) {
  const int32_t s = slot_[brick_index(b)];
  return s < 0 ? nullptr : data_.data() + size_t(s) * kBrickVoxels;
}

void BrickField::set_brick_constant(const glm::ivec3& b, float value) { constant_[brick_index(b)] = value; }

void BrickField::set(int i, int j, int k, float value) {
  const glm::ivec3 b(i / kBrick, j / kBrick, k / kBrick);
  allocate(b);
  brick_data(b)[((k % kBrick) * kBrick + (j % kBrick)) * kBrick + (i % kBrick)] = value;
}

namespace {
// Four floats as one SSE / NEON register (a GCC and Clang vector extension): a stencil row along x.
using Row = float __attribute__((vector_size(16)));

// Catmull-Rom weights and their derivatives for the 4 samples at -1, 0, 1, 2 around t in [0, 1].
void catmull_rom(double t, double w[4], double dw[4]) {
  const double t2 = t * t, t3 = t2 * t;
  w[0] = 0.5 * (-t3 + 2 * t2 - t);
  w[1] = 0.5 * (3 * t3 - 5 * t2 + 2);
  w[2] = 0.5 * (-3 * t3 + 4 * t2 + t);
  w[3] = 0.5 * (t3 - t2);
  dw[0] = 0.5 * (-3 * t2 + 4 * t - 1);
  dw[1] = 0.5 * (9 * t2 - 10 * t);
  dw[2] = 0.5 * (-9 * t2 + 8 * t + 1);
  dw[3] = 0.5 * (3 * t2 - 2 * t);
}
}  // namespace

double BrickField::sample_cubic(const glm::dvec3& p, glm::dvec3* gradient) const {
  const BrickField* self = this;
  double v;
  glm::dvec3 g;
  sample_cubic_many(&self, 1, p, &v, &g);
  if (gradient) *gradient = g;
  return v;
}

void BrickField::sample_cubic_many(const BrickField* const* fields, int count, const glm::dvec3& p, double* values,
                                   glm::dvec3* gradients) {
  const BrickField& f0 = *fields[0];
  // Far outside the grid every sample is clamped to its face anyway; clamping p first keeps the int conversion below
  // defined (a NaN becomes the grid's corner rather than undefined behaviour and a wild read).
  glm::dvec3 q;
  for (int a = 0; a < 3; ++a) q[a] = std::isfinite(p[a]) ? std::clamp(p[a], -2.0, double(f0.grid_.dims[a]) + 1.0) : -2.0;
  const glm::dvec3 fl = glm::floor(q);
  const glm::ivec3 base(fl);
  const glm::dvec3 t = q - fl;
  double wx[4], wy[4], wz[4], dx[4], dy[4], dz[4];
  catmull_rom(t.x, wx, dx);
  catmull_rom(t.y, wy, dy);
  catmull_rom(t.z, wz, dz);
  // The 4x4x4 samples (clamped to the grid) by brick and offset, computed once per axis: this gather is the hot
  // loop of the closest point embedding's Newton projections.
  int bx[4], by[4], bz[4], ox[4], oy[4], oz[4];
  for (int a = 0; a < 4; ++a) {
    const int x = std::clamp(base.x + a - 1, 0, f0.grid_.dims.x - 1);
    const int y = std::clamp(base.y + a - 1, 0, f0.grid_.dims.y - 1);
    const int z = std::clamp(base.z + a - 1, 0, f0.grid_.dims.z - 1);
    bx[a] = x / kBrick;
    ox[a] = x % kBrick;
    by[a] = y / kBrick;
    oy[a] = y % kBrick;
    bz[a] = z / kBrick;
    oz[a] = z % kBrick;
  }
  // Per (z, y) row of the stencil, the products of its y and z weights: the value's and d/dx's (wyz), d/dy's (wdy),
  // d/dz's (wdz). The rows are then summed as 4-lane float vectors along x (Row below), one row per step, and the x
  // weights applied once per field at the end.
  Row wyz[16], wdy[16], wdz[16];
  for (int c = 0; c < 4; ++c)
    for (int b = 0; b < 4; ++b) {
      wyz[c * 4 + b] = Row{} + float(wz[c] * wy[b]);
      wdy[c * 4 + b] = Row{} + float(wz[c] * dy[b]);
      wdz[c * 4 + b] = Row{} + float(dz[c] * wy[b]);
    }
  // The samples span at most two bricks per axis. A row whose four x samples are consecutive voxels of one brick
  // (5 positions of 8, away from the grid's faces) is one 16-byte load; other rows are gathered sample by sample.
  int sx[4];
  for (int a = 0; a < 4; ++a) sx[a] = bx[a] - bx[0];
  const bool x_run = sx[3] == 0 && ox[3] == ox[0] + 3;
  for (int m = 0; m < count; ++m) {
    const BrickField& f = *fields[m];
    const float* bricks[2][2][2];  // [z][y][x] of the 2 x 2 x 2 bricks the stencil can touch; null: constant
    float constants[2][2][2];
    for (int c = 0; c < 2; ++c)
      for (int b = 0; b < 2; ++b)
        for (int a = 0; a < 2; ++a) {
          const int zb = std::min(bz[0] + c, f.brick_dims_.z - 1), yb = std::min(by[0] + b, f.brick_dims_.y - 1),
                    xb = std::min(bx[0] + a, f.brick_dims_.x - 1);
          const size_t brick = (size_t(zb) * size_t(f.brick_dims_.y) + size_t(yb)) * size_t(f.brick_dims_.x) + size_t(xb);
          const int32_t slot = f.slot_[brick];
          bricks[c][b][a] = slot < 0 ? nullptr : f.data_.data() + size_t(slot) * kBrickVoxels;
          constants[c][b][a] = f.constant_[brick];
        }
    Row sum{}, sum_dy{}, sum_dz{};
    for (int c = 0; c < 4; ++c)
      for (int b = 0; b < 4; ++b) {
        const float* const* data = bricks[bz[c] - bz[0]][by[b] - by[0]];
        const float* constant = constants[bz[c] - bz[0]][by[b] - by[0]];
        const int offset = (oz[c] * kBrick + oy[b]) * kBrick;
        Row v;
        if (x_run && data[0]) {
          std::memcpy(&v, data[0] + offset + ox[0], sizeof(v));
        } else {
          for (int a = 0; a < 4; ++a) v[a] = data[sx[a]] ? data[sx[a]][offset + ox[a]] : constant[sx[a]];
        }
        sum += wyz[c * 4 + b] * v;
        sum_dy += wdy[c * 4 + b] * v;
        sum_dz += wdz[c * 4 + b] * v;
      }
    double v = 0;
    glm::dvec3 g(0.0);
    for (int a = 0; a < 4; ++a) {
      v += wx[a] * double(sum[a]);
      g.x += dx[a] * double(sum[a]);
      g.y += wx[a] * double(sum_dy[a]);
      g.z += wx[a] * double(sum_dz[a]);
    }
    values[m] = v;
    if (gradients) gradients[m] = g;
  }
}

double BrickField::sample_linear(const glm::dvec3& p) const {
  const glm::dvec3 f = glm::floor(p);
  const glm::ivec3 b(f);
  const glm::dvec3 t = p - f;
  double v = 0;
  for (int c = 0; c < 2; ++c)
    for (int bb = 0; bb < 2; ++bb)
      for (int a = 0; a < 2; ++a)
        v += (a ? t.x : 1 - t.x) * (bb ? t.y : 1 - t.y) * (c ? t.z : 1 - t.z) * at(b.x + a, b.y + bb, b.z + c);
  return v;
}

}  // namespace cpmesh::fields
