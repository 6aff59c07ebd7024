#include "fields/curve_fit.h"

#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "fields/grid.h"

namespace cpmesh::fields {

LocalCurve fit_local_curve(const std::vector<glm::dvec3>& points, const std::vector<uint32_t>& near, size_t i,
                           double sigma) {
  const glm::dvec3 p = points[i];
  auto weight = [&](const glm::dvec3& d) { return std::exp(-0.5 * glm::dot(d, d) / (sigma * sigma)); };
  double W = 0;
  glm::dvec3 c(0.0);
  for (uint32_t j : near) {
    const double w = weight(points[j] - p);
    W += w;
    c += w * points[j];
  }
  c /= W;
  glm::dmat3 C(0.0);
  for (uint32_t j : near) {
    const glm::dvec3 e = points[j] - c;
    C += weight(points[j] - p) * glm::outerProduct(e, e);
  }
  LocalCurve out;
  // Tangent: the principal axis (power iteration from the axis of the largest diagonal entry).
  glm::dvec3 t(0.0);
  t[C[0][0] >= C[1][1] && C[0][0] >= C[2][2] ? 0 : (C[1][1] >= C[2][2] ? 1 : 2)] = 1.0;
  for (int it = 0; it < 40; ++it) {
    const glm::dvec3 n = C * t;
    if (glm::length(n) < 1e-30) return out;
    t = glm::normalize(n);
  }
  const glm::dvec3 u = glm::normalize(glm::cross(t, std::fabs(t.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0)));
  const glm::dvec3 v = glm::cross(t, u);
  // Both coordinates across the tangent as a + b s + c s^2 in the arc parameter s / sigma, by weighted least squares.
  glm::dmat3 A(0.0);
  glm::dvec3 ru(0.0), rv(0.0);
  for (uint32_t j : near) {
    const glm::dvec3 d = points[j] - p;
    const double w = weight(d);
    const double s = glm::dot(d, t) / sigma;
    const glm::dvec3 phi(1.0, s, s * s);
    A += w * glm::outerProduct(phi, phi);
    ru += w * glm::dot(d, u) * phi;
    rv += w * glm::dot(d, v) * phi;
  }
  if (std::fabs(glm::determinant(A)) < 1e-9 * W * W * W) return out;  // all points at one spot: no curve to fit
  const glm::dmat3 Ai = glm::inverse(A);
  const glm::dvec3 cu = Ai * ru, cv = Ai * rv;
  double residual = 0;
  for (uint32_t j : near) {
    const glm::dvec3 d = points[j] - p;
    const double s = glm::dot(d, t) / sigma;
    const glm::dvec3 phi(1.0, s, s * s);
    const double eu = glm::dot(d, u) - glm::dot(cu, phi), ev = glm::dot(d, v) - glm::dot(cv, phi);
    residual += weight(d) * (eu * eu + ev * ev);
  }
  out.valid = true;
  out.offset = u * cu.x + v * cv.x;
  out.rms = std::sqrt(residual / W);
  // Curvature of r(x) = (x, u(x), v(x)) at x = 0: |r' x r''| / |r'|^3 with x = s sigma.
  const glm::dvec3 d1(1.0, cu.y / sigma, cv.y / sigma), d2(0.0, 2 * cu.z / (sigma * sigma), 2 * cv.z / (sigma * sigma));
  out.curvature = glm::length(glm::cross(d1, d2)) / std::pow(glm::length(d1), 3);
  return out;
}

std::vector<LocalCurve> fit_local_curves(const std::vector<glm::dvec3>& points, double sigma) {
  const double reach = 3.0 * sigma;
  const PointBuckets buckets(points.size(), [&](size_t i) { return points[i]; }, reach);
  std::vector<LocalCurve> fits(points.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, points.size()), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<uint32_t> near;
    for (size_t i = r.begin(); i < r.end(); ++i) {
      near.clear();
      buckets.for_each_candidate(points[i], [&](uint32_t j) {
        if (glm::length(points[j] - points[i]) < reach) near.push_back(j);
      });
      fits[i] = fit_local_curve(points, near, i, sigma);
    }
  });
  return fits;
}

}  // namespace cpmesh::fields
