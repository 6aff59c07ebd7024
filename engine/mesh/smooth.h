#pragma once
// Smoothing of the interface meshes after extraction: the restricted Delaunay triangles of a relaxed particle
// system are good where the particles are evenly spread, but graded sizing and the junctions leave a tail of
// flattened triangles. Each round moves every vertex towards the area-weighted centroid of its triangles (interface
// vertices, in the surface) or the midpoint of its two curve neighbours (triple-curve vertices, along the curve),
// puts it back on its feature with the Newton projection of the smooth fields (the embedding's own construction), and
// keeps the move only if none of its triangles flips and the worst radius ratio among them does not get worse
// ("smart" Laplacian smoothing). Quadruple points do not move. Connectivity is unchanged, so the interfaces stay
// conforming along the curves and manifold where they were.
#include <array>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

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

// Sliver removal in a volume mesh by moving its free vertices: TetGen's refinement stops short of its dihedral bound
// for a few tets, and with the interface triangles kept (no Steiner points on them) only the inner vertices can move.
// Each pass visits the vertices >= `fixed` of every tet whose smallest dihedral angle is below target_deg and tries
// the centroid of its neighbours and shrinking random steps, keeping the position that most raises the smallest
// dihedral angle of its tets without inverting any or taking one over the radius-edge bound (or over its own
// ratio where that is higher). Deterministic. Returns the smallest dihedral angle before and after.
struct TetImproveReport {
  double min_dihedral_before = 0, min_dihedral_after = 0;  // degrees
  size_t moves = 0;
};
TetImproveReport improve_tets(std::vector<glm::dvec3>& points, const std::vector<std::array<uint32_t, 4>>& tets,
                              size_t fixed, double target_deg = 12.0, double max_radius_edge = 1.5, int passes = 4);

}  // namespace cpmesh::mesh
