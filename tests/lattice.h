#pragma once
// Patches of the equilateral triangle lattice for the interface edit tests (flips, collapses): rows of unit edges,
// odd rows shifted by half an edge, every triangle oriented alike.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>

#include "fields/closest_point_embedding.h"
#include "mesh/extract.h"
#include "mesh/quality.h"

namespace cpmesh::test {

inline const double kRowHeight = std::sqrt(0.75);

// The triangles between rows j and j + 1 for j < rows - 1, columns 0..columns - 1, with at(i, j) the vertex index;
// each pushed with `pair`.
inline void add_lattice_triangles(mesh::InterfaceMesh& m, int columns, int rows,
                                  const std::function<uint32_t(int, int)>& at, std::array<uint16_t, 2> pair) {
  for (int j = 0; j + 1 < rows; ++j)
    for (int i = 0; i + 1 < columns; ++i) {
      if (j % 2 == 0) {
        m.triangles.push_back({at(i, j), at(i + 1, j), at(i, j + 1)});
        m.triangles.push_back({at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)});
      } else {
        m.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        m.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      }
      m.pair.insert(m.pair.end(), 2, pair);
    }
}

// A columns x rows patch in the plane z = 0 (vertex j * columns + i at (i + (j odd) / 2, j * kRowHeight)), one
// interface 0/1 of interface vertices, every triangle's normal up and every face 7.
inline mesh::InterfaceMesh lattice(int columns, int rows) {
  mesh::InterfaceMesh m;
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < columns; ++i) m.vertices.push_back({i + 0.5 * (j % 2), j * kRowHeight, 0.0});
  add_lattice_triangles(m, columns, rows, [&](int i, int j) { return uint32_t(j * columns + i); }, {0, 1});
  m.face.assign(m.triangles.size(), 7);
  m.vertex_kind.assign(m.vertices.size(), uint8_t(fields::FeatureKind::interface));
  return m;
}

inline double worst_ratio(const mesh::InterfaceMesh& m) {
  double worst = 1;
  for (const auto& t : m.triangles)
    worst = std::min(worst, mesh::radius_ratio(m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]));
  return worst;
}

inline bool every_normal_up(const mesh::InterfaceMesh& m) {
  return std::all_of(m.triangles.begin(), m.triangles.end(), [&](const auto& t) {
    const auto& V = m.vertices;
    return glm::cross(V[t[1]] - V[t[0]], V[t[2]] - V[t[0]]).z > 0;
  });
}

}  // namespace cpmesh::test
