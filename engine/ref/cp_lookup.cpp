#include "ref/cp_lookup.h"

#include <algorithm>
#include <cmath>

namespace cpmesh::ref {

namespace {

// The two quadratics WENO4 blends: on samples {-1, 0, 1} (side 0) and {0, 1, 2} (side 1), at t in [0, 1).
template <typename T>
T quadratic(const T& f0, const T& f1, const T& f2, const T& f3, float t, int side) {
  return side == 0 ? f1 + 0.5f * (f2 - f0) * t + 0.5f * (f2 - 2.0f * f1 + f0) * t * t
                   : f1 + 0.5f * (-f3 + 4.0f * f2 - 3.0f * f1) * t + 0.5f * (f3 - 2.0f * f2 + f1) * t * t;
}

// For float and for glm::vec4, lane by lane the same float32 operations (the lookup interpolates the four components
// of its fine points at once).
template <typename T>
T weno4_of(const T& f0, const T& f1, const T& f2, const T& f3, float t) {
  // Two quadratic interpolants, on {-1, 0, 1} and {0, 1, 2}; ideal weights (2 - t)/3 and (t + 1)/3 make their blend
  // the cubic interpolant; the smoothness indicators are written in differences from the centre values so float32
  // keeps them accurate when the values (coordinates) are large.
  const T p1 = quadratic(f0, f1, f2, f3, t, 0), p2 = quadratic(f0, f1, f2, f3, t, 1);
  const T a = f0 - f1, b = f2 - f1, c = f1 - f2, d = f3 - f2;
  const T is1 = (13.0f * a * a + 26.0f * a * b + 25.0f * b * b) / 12.0f;
  const T is2 = (25.0f * c * c + 26.0f * c * d + 13.0f * d * d) / 12.0f;
  const float eps = 1e-6f;
  const T alpha1 = ((2.0f - t) / 3.0f) / ((eps + is1) * (eps + is1));
  const T alpha2 = ((t + 1.0f) / 3.0f) / ((eps + is2) * (eps + is2));
  return (alpha1 * p1 + alpha2 * p2) / (alpha1 + alpha2);
}

// margin: how much nearer than the blend a quadratic must lie to be taken.
glm::vec4 nearest_candidate(const glm::vec4 (&v)[4][4][4], const glm::vec3& t, const glm::vec3& query, float margin) {
  // The WENO4 tensor product, and the eight tensor products of one-sided quadratics (a side per axis).
  glm::vec4 wy[4][4], wz[4], qy[2][4][4], qz[4][4], q[8];
  for (int z = 0; z < 4; ++z)
    for (int y = 0; y < 4; ++y) {
      const glm::vec4* l = v[z][y];
      wy[z][y] = weno4_lookup(l[0], l[1], l[2], l[3], t.x);
      for (int a = 0; a < 2; ++a) qy[a][z][y] = quadratic(l[0], l[1], l[2], l[3], t.x, a);
    }
  for (int z = 0; z < 4; ++z) {
    wz[z] = weno4_lookup(wy[z][0], wy[z][1], wy[z][2], wy[z][3], t.y);
    for (int a = 0; a < 2; ++a)
      for (int b = 0; b < 2; ++b) {
        const auto& l = qy[a][z];
        qz[a * 2 + b][z] = quadratic(l[0], l[1], l[2], l[3], t.y, b);
      }
  }
  const glm::vec4 weno = weno4_lookup(wz[0], wz[1], wz[2], wz[3], t.z);
  for (int ab = 0; ab < 4; ++ab)
    for (int c = 0; c < 2; ++c) q[ab * 2 + c] = quadratic(qz[ab][0], qz[ab][1], qz[ab][2], qz[ab][3], t.z, c);
  glm::vec3 best = glm::vec3(weno);
  float best_d = glm::length(best - query) - margin;
  for (const glm::vec4& c : q) {
    const float d = glm::length(glm::vec3(c) - query);
    if (d < best_d) best_d = d, best = glm::vec3(c);
  }
  return glm::vec4(best, weno.w);
}

}  // namespace

float weno4(float f0, float f1, float f2, float f3, float t) { return weno4_of(f0, f1, f2, f3, t); }

glm::vec4 weno4_lookup(const glm::vec4& f0, const glm::vec4& f1, const glm::vec4& f2, const glm::vec4& f3, float t) {
  glm::vec4 r = weno4_of(f0, f1, f2, f3, t);
  r.w = std::clamp(r.w, std::min(std::min(f0.w, f1.w), std::min(f2.w, f3.w)),
                   std::max(std::max(f0.w, f1.w), std::max(f2.w, f3.w)));
  return r;
}

CpResult cp_lookup(const fields::ClosestPointEmbedding& E, const glm::vec3& local, uint32_t feature) {
  CpResult r;
  r.value = glm::vec4(local, 0.0f);
  const int sub = E.sub;
  const glm::vec3 u = local / glm::vec3(E.grid.spacing) * float(sub);
  // Outside the fine grid (NaN included) nothing is found; checked before the conversion to int, which would
  // overflow (a NaN or a huge coordinate became a stencil far outside the table).
  const glm::vec3 fine_dims = glm::vec3(E.grid.dims * sub);
  if (!(u.x >= 0 && u.y >= 0 && u.z >= 0 && u.x < fine_dims.x && u.y < fine_dims.y && u.z < fine_dims.z)) return r;
  const glm::vec3 g0 = glm::floor(u);
  const glm::vec3 t = u - g0;
  const glm::ivec3 base = glm::ivec3(g0) - 1;
  // The cells the stencil touches, each block found once (as the shader does).
  if (glm::any(glm::lessThan(base, glm::ivec3(0)))) return r;
  const glm::ivec3 c0 = base / sub, c1 = (base + 3) / sub;
  if (glm::any(glm::greaterThanEqual(c1, E.grid.dims))) return r;
  int64_t cell_block[64];
  for (int z = 0; z <= c1.z - c0.z; ++z)
    for (int y = 0; y <= c1.y - c0.y; ++y)
      for (int x = 0; x <= c1.x - c0.x; ++x) {
        const glm::ivec3 cell = c0 + glm::ivec3(x, y, z);
        const int64_t block = E.find_block(E.grid.index(cell.x, cell.y, cell.z), feature);
        if (block < 0) return r;
        cell_block[(z * 4 + y) * 4 + x] = block;
      }
  glm::vec4 v[4][4][4];
  for (int z = 0; z < 4; ++z)
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 4; ++x) {
        const glm::ivec3 f = base + glm::ivec3(x, y, z);
        const glm::ivec3 cell = f / sub, s = f - cell * sub, c = cell - c0;
        const int64_t block = cell_block[(c.z * 4 + c.y) * 4 + c.x];
        v[z][y][x] = E.fine[size_t(block) * size_t(sub * sub * sub) + size_t((s.z * sub + s.y) * sub + s.x)];
      }
  r.value = nearest_candidate(v, t, local, kBlendMargin * float(E.grid.min_spacing()));
  r.valid = true;
  return r;
}

}  // namespace cpmesh::ref
