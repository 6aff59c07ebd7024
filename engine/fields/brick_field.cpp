#include "fields/brick_field.h"

#include <algorithm>

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
  // The samples span at most two bricks per axis: resolve those (up to 8) once per field, then index within them.
  int sx[4], sy[4], sz[4];  // which of the two bricks, per axis and sample
  for (int a = 0; a < 4; ++a) {
    sx[a] = bx[a] - bx[0];
    sy[a] = by[a] - by[0];
    sz[a] = bz[a] - bz[0];
  }
  for (int m = 0; m < count; ++m) {
    const BrickField& f = *fields[m];
    const float* data[2][2][2];
    float constant[2][2][2];
    bool zero = true;  // every brick constant 0 (a junction offset away from the curves): the sample is 0, and so
                       // is its gradient, without the gather
    for (int c = 0; c < 2; ++c)
      for (int b = 0; b < 2; ++b)
        for (int a = 0; a < 2; ++a) {
          const int zb = std::min(bz[0] + c, f.brick_dims_.z - 1), yb = std::min(by[0] + b, f.brick_dims_.y - 1),
                    xb = std::min(bx[0] + a, f.brick_dims_.x - 1);
          const size_t brick = (size_t(zb) * size_t(f.brick_dims_.y) + size_t(yb)) * size_t(f.brick_dims_.x) + size_t(xb);
          const int32_t slot = f.slot_[brick];
          data[c][b][a] = slot < 0 ? nullptr : f.data_.data() + size_t(slot) * kBrickVoxels;
          constant[c][b][a] = f.constant_[brick];
          zero = zero && slot < 0 && constant[c][b][a] == 0.0f;
        }
    if (zero) {
      values[m] = 0.0;
      if (gradients) gradients[m] = glm::dvec3(0.0);
      continue;
    }
    double v = 0;
    glm::dvec3 g(0.0);
    for (int c = 0; c < 4; ++c)
      for (int b = 0; b < 4; ++b) {
        const int offset_row = (oz[c] * kBrick + oy[b]) * kBrick;
        double row = 0, row_dx = 0;
        for (int a = 0; a < 4; ++a) {
          const float* d = data[sz[c]][sy[b]][sx[a]];
          const double s = d ? d[offset_row + ox[a]] : constant[sz[c]][sy[b]][sx[a]];
          row += wx[a] * s;
          row_dx += dx[a] * s;
        }
        v += wz[c] * wy[b] * row;
        g.x += wz[c] * wy[b] * row_dx;
        g.y += wz[c] * dy[b] * row;
        g.z += dz[c] * wy[b] * row;
      }
    values[m] = v;
    if (gradients) gradients[m] = g;
  }
}

void BrickField::sample_linear_many(const BrickField* const* fields, int count, const glm::dvec3& p, double* values) {
  if (count <= 0) return;
  const BrickField& f0 = *fields[0];
  const glm::dvec3 fl = glm::floor(p);
  const glm::ivec3 b(fl);
  const glm::dvec3 t = p - fl;
  // The corners as at() clamps them, in sample_linear's order, with its weights multiplied in its order.
  size_t brick[8], offset[8];
  double weight[8];
  for (int c = 0, n = 0; c < 2; ++c)
    for (int bb = 0; bb < 2; ++bb)
      for (int a = 0; a < 2; ++a, ++n) {
        const int i = std::clamp(b.x + a, 0, f0.grid_.dims.x - 1), j = std::clamp(b.y + bb, 0, f0.grid_.dims.y - 1),
                  k = std::clamp(b.z + c, 0, f0.grid_.dims.z - 1);
        brick[n] = f0.brick_index(glm::ivec3(i / kBrick, j / kBrick, k / kBrick));
        offset[n] = size_t(((k % kBrick) * kBrick + (j % kBrick)) * kBrick + (i % kBrick));
        weight[n] = (a ? t.x : 1 - t.x) * (bb ? t.y : 1 - t.y) * (c ? t.z : 1 - t.z);
      }
  for (int m = 0; m < count; ++m) {
    const BrickField& f = *fields[m];
    double v = 0;
    for (int n = 0; n < 8; ++n) {
      const int32_t s = f.slot_[brick[n]];
      v += weight[n] * (s < 0 ? f.constant_[brick[n]] : f.data_[size_t(s) * kBrickVoxels + offset[n]]);
    }
    values[m] = v;
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
