#pragma once
// Edge flips inside one interface, where they lift the worse of the two triangles across the edge.
//
// The smoothing (smooth.h) moves vertices and keeps the connectivity the restricted Delaunay gave; beside the triple
// curves that connectivity is often the worse of two: a curve vertex joined to an interface vertex across a thin
// triangle whose flipped diagonal would give two fair ones. An edge of exactly two triangles of one interface,
// oriented alike (one runs a -> b, the other b -> a), is flipped to the other diagonal of their quad where
//  - the smaller radius ratio of the two triangles grows by at least `min_gain`;
//  - the quad is nearly flat (its two triangles' normals within `max_fold_deg`, before and after), so the surface
//    keeps its place: the new edge lies on it to within the quad's fold;
//  - the new edge is no edge of any triangle yet (so every edge keeps its triangles: manifold edges stay manifold and
//    no new curve edge appears), and each end of the old one keeps at least three triangles;
//  - once every flip of a pass is made, no flipped triangle crosses another (flips undone until none does).
// Each pass makes the flips of edges whose triangles no other flip of the pass touches, best gain first; passes repeat
// until one makes none. A flipped triangle keeps its pair and orientation (normal from pair[0] into pair[1]); its
// `face` becomes kNoFace, as it is no face of the restricted Delaunay tets any more.
// Sequential and deterministic.
#include <cstddef>
#include <cstdint>
#include <limits>

#include "mesh/extract.h"

namespace cpmesh::mesh {

struct FlipOptions {
  double min_gain = 0.02;     // radius ratio
  double max_fold_deg = 15;   // between the normals of the quad's two triangles
  int passes = 5;
};

struct FlipReport {
  size_t flips = 0;   // kept
  size_t undone = 0;  // undone for a crossing
};

constexpr uint32_t kNoFace = std::numeric_limits<uint32_t>::max();

FlipReport flip_interface_edges(InterfaceMesh& mesh, const FlipOptions& options = {});

}  // namespace cpmesh::mesh
