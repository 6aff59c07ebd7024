#pragma once
// Points inside a material for TetGen to start its quality refinement from (given after the surface vertices, they
// come back among the points it added, free to move).
//
// TetGen refining from the surface vertices alone starts from the Delaunay tets between them, long tets across the
// material, and spends most of its time refining them (stop 46: `p` alone is 8.3-8.9 s of 25-30 on material 4 of the
// paper-size head). Points of an octree graded from the surface let it start closer to its own output: on the
// head:250 surfaces (one core, runs side by side), material 4 (282k surface vertices) 27.9 -> 14.5 s, 1.74 M tets
// either way (40k points given, TetGen then adds 103k instead of 143k); material 1 (800k) 74.3 -> 54.9 s, 4.80 ->
// 4.76 M tets. Given much denser (a finer octree, or points nearer the surface) the tets grow by 8-80% and the time
// comes back; a BCC lattice of one spacing (stop 46) did not help.
//
// The sizing is s(x) = min over the surface vertices v of (h_v + grading |x - v|), h_v the mean length of v's edges.
// A cube of the octree over the surface's bounding box is split while its edge is over `cell` x s(centre); a leaf's
// centre is a point where it lies inside the surface (ray parity, mesh/parity_test.h) and no surface vertex lies
// within clearance x s. grading x cell must be at least 1, so that a cube is only split where a surface vertex lies
// within its edge of its centre. No points where a vertex's edges all have no length.
//
// Inputs:  points     any points; only those the triangles use count
//          triangles  closed surfaces (a material's boundary; pieces of it or nested ones by parity)
// Outputs: the leaves' centres, in depth-first order of the octree: the same on any thread count.
#include <array>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::mesh {

struct InteriorPointOptions {
  double grading = 0.6;    // s grows by this much per unit of distance from the surface
  double cell = 2.0;       // a cube is split while its edge exceeds cell x s at its centre
  double clearance = 0.7;  // a leaf's centre is kept only where every surface vertex is at least clearance x s away
                           // (> 0)
};

std::vector<glm::dvec3> interior_points(const std::vector<glm::dvec3>& points,
                                        const std::vector<std::array<uint32_t, 3>>& triangles,
                                        const InteriorPointOptions& options = {});

}  // namespace cpmesh::mesh
