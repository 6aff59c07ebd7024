#pragma once
// Analytic volumes built in memory (DESIGN.md "Synthetic test volumes"), with their known answers.
#include <cmath>
#include <vector>

#include "fields/grid.h"

namespace cpmesh::synth {

struct TestVolume {
  fields::Grid grid;
  std::vector<uint16_t> labels;
  glm::dvec3 centre{0.0};
  std::vector<glm::dvec3> quadruple_points;  // local coordinates
  // Wedge ball only: the geometry, for distances to the analytic triple curves.
  double outer_radius = 0, inner_radius = 0, rotation = 0;
  glm::dvec3 inner_centre{0.0};
};

// Label 1 inside a sphere (voxel centres closer than radius), 0 outside, in an n^3 grid of unit spacing.
inline TestVolume sphere_volume(int n, const glm::dvec3& centre, double radius) {
  TestVolume v;
  v.grid = fields::Grid{{n, n, n}, {1, 1, 1}, {0, 0, 0}};
  v.centre = centre;
  v.labels.resize(v.grid.voxel_count());
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        v.labels[v.grid.index(i, j, k)] = glm::length(glm::dvec3(i, j, k) - centre) < radius ? 1 : 0;
  return v;
}

// The wedge ball scaled to n^3 (128^3: ball radius 50): background 0; three wedges 1, 2, 3 split by half-planes
// through the vertical axis; an off-centre inner ball 4 (radius 18) that contains a piece of the axis and so crosses
// every wedge plane. 9 interfaces, 8 triple curves, 4 quadruple points.
inline TestVolume wedge_ball_volume(int n) {
  TestVolume v;
  const double s = n / 128.0, R = 50 * s, r = 18 * s, rot = 0.3;
  v.grid = fields::Grid{{n, n, n}, {1, 1, 1}, {0, 0, 0}};
  v.centre = glm::dvec3((n - 1) / 2.0 + 0.1, (n - 1) / 2.0 - 0.2, (n - 1) / 2.0 + 0.15);
  const glm::dvec3 inner = v.centre + s * glm::dvec3(6, 4, 5);
  v.labels.resize(v.grid.voxel_count());
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const glm::dvec3 p(i, j, k);
        uint16_t label = 0;
        if (glm::length(p - inner) < r) {
          label = 4;
        } else if (glm::length(p - v.centre) < R) {
          double a = std::atan2(p.y - v.centre.y, p.x - v.centre.x) - rot;
          while (a < 0) a += 2 * M_PI;
          label = uint16_t(1 + int(a / (2 * M_PI / 3)) % 3);
        }
        v.labels[v.grid.index(i, j, k)] = label;
      }
  v.outer_radius = R;
  v.inner_radius = r;
  v.rotation = rot;
  v.inner_centre = inner;
  const double dz = std::sqrt(r * r - (36 + 16) * s * s);
  v.quadruple_points = {v.centre + glm::dvec3(0, 0, R), v.centre - glm::dvec3(0, 0, R),
                        glm::dvec3(v.centre.x, v.centre.y, inner.z + dz), glm::dvec3(v.centre.x, v.centre.y, inner.z - dz)};
  return v;
}

// Distance from p to the wedge ball's analytic triple curve(s) of labels a < b < c: the outer sphere's meridian on
// the plane between two wedges (0, wedge, wedge), the vertical axis (1, 2, 3), or the circle where a wedge plane
// cuts the inner ball (wedge, wedge, 4).
inline double wedge_ball_curve_distance(const TestVolume& v, int a, int b, int c, const glm::dvec3& p) {
  // The plane between wedges i and i+1 (labels 1..3, cyclic) is at angle rotation + 120 deg * i.
  auto plane_angle = [&](int w1, int w2) {
    const int lo = std::min(w1, w2), hi = std::max(w1, w2);
    const int boundary = (lo == 1 && hi == 3) ? 0 : lo;  // 3|1 at 0, 1|2 at 1, 2|3 at 2
    return v.rotation + boundary * 2.0 * M_PI / 3.0;
  };
  const glm::dvec3 q = p - v.centre;
  if (a == 1 && b == 2 && c == 3) return std::sqrt(q.x * q.x + q.y * q.y);
  const bool outer = a == 0;
  const double th = outer ? plane_angle(b, c) : plane_angle(a, b);
  const glm::dvec3 dir(std::cos(th), std::sin(th), 0.0), normal(-std::sin(th), std::cos(th), 0.0);
  const double off_plane = glm::dot(q, normal);
  if (outer) {
    const glm::dvec2 in_plane(glm::dot(q, dir), q.z);
    return std::sqrt(off_plane * off_plane + std::pow(glm::length(in_plane) - v.outer_radius, 2));
  }
  const glm::dvec3 ci = v.inner_centre - v.centre;
  const double dc = glm::dot(ci, normal);
  const glm::dvec3 cc = ci - dc * normal;  // the circle's centre, in the plane
  const double rc = std::sqrt(std::max(0.0, v.inner_radius * v.inner_radius - dc * dc));
  const glm::dvec3 pp = q - off_plane * normal;
  return std::sqrt(off_plane * off_plane + std::pow(glm::length(pp - cc) - rc, 2));
}

}  // namespace cpmesh::synth
