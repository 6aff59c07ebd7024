#pragma once
// A surface's triangles renumbered over its own vertices, in order of first use: for the code that works on one
// material's boundary out of all the points (split_material, interior_points).
#include <array>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::mesh {

struct LocalSurface {
  std::vector<uint32_t> global;               // local vertex -> index into the caller's points
  std::vector<glm::dvec3> points;             // the vertices' positions
  std::vector<std::array<uint32_t, 3>> triangles;  // over local vertices
};

inline LocalSurface local_surface(const std::vector<glm::dvec3>& points,
                                  const std::vector<std::array<uint32_t, 3>>& triangles) {
  LocalSurface s;
  std::vector<uint32_t> local(points.size(), UINT32_MAX);
  s.triangles.resize(triangles.size());
  for (size_t t = 0; t < triangles.size(); ++t)
    for (size_t k = 0; k < 3; ++k) {
      uint32_t& l = local[triangles[t][k]];
      if (l == UINT32_MAX) {
        l = uint32_t(s.global.size());
        s.global.push_back(triangles[t][k]);
        s.points.push_back(points[triangles[t][k]]);
      }
      s.triangles[t][k] = l;
    }
  return s;
}

}  // namespace cpmesh::mesh
