#pragma once
// Random points in the unit ball for the Delaunay-based mesh tests, and a tet's centroid.
#include <random>
#include <vector>

#include <glm/glm.hpp>

#include "mesh/tetgen.h"

namespace cpmesh::test {

// n points drawn uniformly in the unit ball by rejection from the cube, from `rng` (which the caller goes on using).
inline std::vector<glm::dvec3> points_in_ball(size_t n, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<glm::dvec3> points;
  while (points.size() < n) {
    const glm::dvec3 p(u(rng), u(rng), u(rng));
    if (glm::length(p) < 1) points.push_back(p);
  }
  return points;
}

inline glm::dvec3 centroid(const mesh::Tets& T, size_t t) {
  glm::dvec3 c(0.0);
  for (uint32_t v : T.tets[t]) c += T.points[v];
  return c / 4.0;
}

}  // namespace cpmesh::test
