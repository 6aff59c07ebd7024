#pragma once
// Face neighbours of a tet mesh.
#include <cstdint>
#include <vector>

#include "mesh/tetgen.h"

namespace cpmesh::mesh {

// neighbour[t * 4 + c] is the (tet * 4 + corner) across the face of tet t opposite corner c; kHull where none.
// DelaunayMesh::tets (delaunay.h) gives it with its tets.
struct Adjacency {
  static constexpr uint32_t kHull = ~0u;
  std::vector<uint32_t> neighbour;
};
// From tets.neighbours where delaunay() filled them (linear, parallel), else by sorting the faces.
Adjacency build_adjacency(const Tets& tets);

}  // namespace cpmesh::mesh
