#pragma once
// Slivers whose vertices lie on the interfaces, mended by moving those vertices along their interfaces and curves.
//
// The volume mesh's sliver passes (smooth.h: improve_tets, split_slivers; remesh_slivers.h) move, add and refill
// inner points only, so a tet whose four vertices are interface vertices keeps its shape: on the corpus's thin walls
// (organs-64's vessel walls, one or two voxels thick) 15 of its 19 tets under 10 degrees were such tets, and the other
// 4 had three interface vertices and one inner one that no move of the inner one mended. This pass moves an interface
// vertex of each tet under the bound a short way along its interface, as Mesh_3's sliver perturber moves surface
// vertices and projects them back: random steps in the plane of its triangles (shrinking, around the best position so
// far), each put back on the vertex's feature by `project`, the best kept if it leaves fewer of the vertex's tets
// under the bound or raises their smallest dihedral angle, and only if
//  - no tet around the vertex turns over and none goes over the radius-edge bound (or its own ratio where higher);
//  - the vertex's star is closed (every face through it is shared by two of its tets), so with no tet turned over the
//    tets around it still tile the same ball and no interface triangle can cross another; or open on the outer
//    boundary (its faces with one tet are its interface triangles with the outside, which is not meshed), and then no
//    triangle of a moved vertex crosses another once the pass is over (moves undone until none does);
//  - its interface triangles keep their shape: the worst radius ratio among them stays at least the smaller of 0.5
//    and its value before, and none turns more than 30 degrees.
// Connectivity does not change, so the interfaces stay conforming and manifold and the tets stay on their faces; the
// surface mesh and the volume mesh share the moved positions. A triple-curve vertex moves the same way, its steps in
// any direction and `project` putting it back on its curve. Where no position on the feature mends a vertex's tets
// (the material across them thinner than its triangles are long: four interface vertices, two on each side, nearly
// in one plane), a second search leaves the feature by up to `max_offset` (along the normal for an interface vertex,
// in any direction for a curve vertex or a quadruple point, which has only this search), with the same rules.
// Flat interface triangles are mended the same way (`min_ratio`): where two quadruple points 0.1-0.4 voxel apart
// or a point beside a curve make a triangle of radius ratio 0.1-0.2 that no flip mends (its long edge is a curve
// edge, or its quad folds), each of its vertices is moved to raise the smallest radius ratio among its triangles,
// with no tet of it taken under the dihedral bound (nor one already under it made worse), under the same rules.
// Sequential and deterministic (the steps are hashed_normal of the vertex, the pass and the draw).
//
// Inputs:  points     the volume mesh's points, the interface vertices first
//          tets       the volume mesh's tets (every material's: a vertex's star must be whole)
//          triangles  the interface triangles over `points`
//          movable    movable[v] for v < movable.size(): 1 for an interface vertex, 2 for a triple-curve vertex, 3 for a
//                     quadruple point or any vertex with no feature to follow (moved only by the offset, so only with
//                     max_offset > 0), 0 (and every point from movable.size() on) for a point that stays
//          project    puts a position near vertex v back on v's feature; false where it cannot
//          options    the bounds, the offset and the passes (SurfaceMoveOptions)
// Outputs: points     moved vertices' new positions
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::mesh {

struct SurfaceSliverReport {
  size_t slivers_before = 0, slivers_after = 0;  // tets under the bound with a movable vertex
  size_t flat_before = 0, flat_after = 0;        // interface triangles under min_ratio with a movable vertex
  size_t moves = 0;                              // vertex moves kept
};

struct SurfaceMoveOptions {
  double target_deg = 12.0;      // the dihedral bound
  double max_radius_edge = 1.5;  // no tet goes over 1.5 times this (or its own ratio where higher)
  double max_offset = 0;         // how far a vertex may leave its feature (0: it stays on it)
  double min_ratio = 0;          // interface triangles under this radius ratio are mended too (0: none)
  int passes = 6;
};

using FeatureProjection = std::function<bool(uint32_t v, const glm::dvec3& near, glm::dvec3& on)>;

SurfaceSliverReport move_surface_vertices(std::vector<glm::dvec3>& points,
                                          const std::vector<std::array<uint32_t, 4>>& tets,
                                          const std::vector<std::array<uint32_t, 3>>& triangles,
                                          const std::vector<uint8_t>& movable, const FeatureProjection& project,
                                          const SurfaceMoveOptions& options = {});

}  // namespace cpmesh::mesh
