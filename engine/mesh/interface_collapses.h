#pragma once
// Edge collapses inside the interfaces, where a vertex crowds a neighbour: the Delaunay refinement (refine.h) adds
// samples where the topology needs them, not where the spacing has room, and around dense junctions (hundreds of
// labels in a small volume) those samples and the particles beside them leave short edges whose triangles no vertex
// move can mend, since the smoothing (smooth.h) and the flips (interface_flips.h) keep every vertex. The collapse of
// edge (b, a) removes b: its triangles take a in its place and the triangles on the edge go. a stays where it is, on
// its feature; the smoothing that follows spreads the vertices around it. It is made where
//  - b lies on an interface or a triple curve (a quadruple point stays), a on a feature of b's closure (a's triangles
//    meet every material b's do: the same interface, its curve or point; the same curve or its point), and a curve
//    vertex goes only along its curve (the edge is a curve edge: one triangle of each of its three interfaces);
//  - the edge is shorter than `max_length` times the smaller sizing h of its ends, so the surface loses no more than
//    that much detail;
//  - the worst radius ratio among b's triangles grows by at least `min_gain`, and no triangle's normal turns by more
//    than `max_turn_deg` from its own before or, for an interface vertex b, from the area-weighted normal of b's
//    triangles (where they fold, a crumple, that is the surface's normal and their own point anywhere);
//  - every edge at a after it is an interface's inner edge (two triangles of one interface) or a curve edge (three or
//    more triangles, each of another interface), neither end is a pinched vertex (each interface's triangles around
//    it one fan: where a sheet touches itself, its two sides lie too close for the crossing test) nor is a after, the
//    link condition holds inside each interface on the edge (its boundary coned to a dummy vertex, so a patch
//    between curves is not collapsed away): the interfaces keep their topology, edge-manifold with their boundaries
//    on the curves, and no vertex becomes pinched;
//  - once every collapse of a pass is made, no changed triangle crosses another (collapses undone until none does).
// The materials a vertex meets are read off its triangles, so what the written mesh says is what is kept. Each pass
// makes the collapses whose triangles no other collapse of the pass touches, best gain first; passes repeat until one
// makes none. Removed vertices stay in the vertex list, in no triangle, as particles left out of the interfaces do
// (the volume mesh keeps only the vertices of its tets). Changed triangles keep their pair and orientation; their `face` becomes kNoFace.
// Sequential and deterministic.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "mesh/extract.h"

namespace cpmesh::mesh {

struct CollapseOptions {
  double max_length = 0.7;    // of the smaller sizing h of the edge's ends
  double min_gain = 0.05;     // radius ratio
  double max_turn_deg = 20;   // between a triangle's normal before and after
  int passes = 5;             // 0: off
};

struct CollapseReport {
  size_t collapses = 0;  // kept
  size_t undone = 0;     // undone for a crossing
};

// vertex_h[v]: the sizing h at vertex v, in the units of mesh.vertices.
CollapseReport collapse_interface_edges(InterfaceMesh& mesh, const std::vector<float>& vertex_h,
                                        const CollapseOptions& options = {});

}  // namespace cpmesh::mesh
