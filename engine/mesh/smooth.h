#pragma once
// Smoothing of the interface meshes after extraction: the restricted Delaunay triangles of a relaxed particle
// system are good where the particles are evenly spread, but graded sizing and the junctions leave a tail of
// flattened triangles. Each round moves every vertex towards the area-weighted centroid of its triangles (interface
// vertices, in the surface) or the midpoint of its two curve neighbours (triple-curve vertices, along the curve),
// puts it back on its feature with the Newton projection of the smooth fields (the embedding's own construction), and
// keeps the move only if none of its triangles flips and the worst radius ratio among them does not get worse
// ("smart" Laplacian smoothing). Quadruple points do not move. Connectivity is unchanged, so the interfaces stay
// conforming along the curves and manifold where they were.
#include <cstdint>
#include <vector>

#include "fields/closest_point_embedding.h"
#include "mesh/extract.h"

namespace cpmesh::mesh {

struct SmoothOptions {
  int rounds = 5;       // 0: off
  double step = 0.8;    // share of the way to the target per round
};

struct SmoothReport {
  int rounds = 0;
  size_t moves = 0;     // accepted vertex moves, all rounds
  size_t refused = 0;   // moves undone (a flip, a worse triangle, or a projection that did not converge)
};

// vertex_feature[v]: the embedding feature of vertex v (interface, triple curve or quadruple point).
SmoothReport smooth_interfaces(const fields::IndicatorFields& fields, const fields::ClosestPointEmbedding& embedding,
                               const std::vector<uint32_t>& vertex_feature, InterfaceMesh& mesh,
                               const SmoothOptions& options = {});

}  // namespace cpmesh::mesh
