#pragma once
// A weighted local quadratic fit of a space curve through one of its sample points: the curve smoothing moves the
// triple curves' points onto it (closest_point_embedding.h), and the sizing field reads their curvature from it.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::fields {

struct LocalCurve {
  bool valid = false;          // false: the points are at one spot, no direction to fit along
  glm::dvec3 offset{0.0};      // from points[i] to the fitted curve, across it
  double curvature = 0;        // of the fitted curve at that point (1 / length)
  double rms = 0;              // weighted rms distance of the points from the fit
};

// Fits the curve through points[i] from the points `near` (indices into points, i among them), weighted by a
// Gaussian of width sigma around points[i]: the tangent is the weighted principal axis, and both coordinates
// across it are quadratics of the arc parameter along it.
LocalCurve fit_local_curve(const std::vector<glm::dvec3>& points, const std::vector<uint32_t>& near, size_t i,
                           double sigma);
// fit_local_curve at every point of one curve's samples, each from its neighbours within 3 sigma (in parallel).
std::vector<LocalCurve> fit_local_curves(const std::vector<glm::dvec3>& points, double sigma);

}  // namespace cpmesh::fields
