#pragma once
// Cutting one material into pieces that TetGen meshes on separate cores (issue 9: one TetGen run per material kept 4
// of 16 cores busy on the paper-size head, its largest run 79 s).
//
// The pieces lie between cut planes across the material's longest extent, each plane near a quantile of the
// estimated work (estimated_tets below: the boundary's vertices below it and, less, the volume below it) but moved
// to where the least area of boundary triangles runs nearly parallel to it close by, as far as the pieces keep
// between 3/4 and `largest` of their share of the work: a separator that meets the boundary at a grazing angle leaves
// slivers in the wedge between them that no pass mends (the paper-size head in 16 pieces: 83 tets under 12 degrees,
// from 8.0, with the planes at the quantiles; 2-3, from 11.0, with the planes moved; 0 in one run per material).
// Each piece is bounded by the material's
// interface triangles on its side and by a separator surface that the pieces on either side of a plane both keep as
// it is (TetGen -Y), so their tets meet face to face and no point is added on it. The separator comes from one
// Delaunay tetrahedralization of the boundary's vertices and a triangular lattice of points on each plane (inside
// the material, kept clear of its boundary): the boundary triangles are Delaunay faces there (the restricted
// Delaunay triangles of the particles; after the smoothing all but a few in 10^4 still are), so a flood from them
// across the other faces tells which tets lie inside the material (ray parity where the flood is in doubt: near a
// boundary triangle that is no Delaunay face). Each inside tet belongs to the piece that holds its centroid, a
// cluster of doubtful tets to its lowest piece, and the separator is the faces between inside tets of different
// pieces: the lattice's own triangles in the open, Delaunay faces joining lattice and boundary points near the
// boundary. TetGen refines each piece up to its fixed boundary; it leaves more slivers along a kept separator than
// in a whole material, which the sliver passes after the merge mesh afresh with the separator free (volume_mesh.h).
//
// It refuses (MaterialSplit::refused says why; the caller meshes the material whole) where it cannot vouch for the
// pieces: a boundary that is not closed, planes that coincide or cross no boundary triangle, a separator face that
// crosses a boundary triangle that is no Delaunay face, an empty piece or one whose boundary is not closed; and where
// it would make a poor mesh: a plane's separator of which more than 30% of the triangles join boundary vertices only
// (the plane crosses thin layers, where both pieces must keep triangles spanning the layer and the slivers along them
// outlast every sliver pass). It throws where the points cannot be tetrahedralized at all (fewer than 4, or flat).
// The cut's Delaunay tetrahedralization runs on every core (delaunay.h), in this process: materials may be cut on
// several threads at once.
//
// Inputs:  points     every point, in the caller's numbering (the boundary's vertices among them)
//          boundary   the material's interface triangles, oriented with their normals out of the material
//          pieces     how many pieces (>= 2): the planes lie near quantiles of the estimated work (halfway between
//                     two distinct vertex coordinates), so that TetGen makes about as many tets in each piece
//          first_new  the number the first new point gets (the caller appends MaterialSplit::points there)
//          largest    the most estimated work a piece may take where a plane moves off grazing boundary, in shares
//                     (the material's work / pieces; >= 1, else std::invalid_argument): mesh_materials allows a
//                     little over the largest run of any material, which sets the time of all runs
// Outputs: MaterialSplit
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::mesh {

struct MaterialSplit {
  std::vector<glm::dvec3> points;                            // the separators' lattice points, from first_new on
  std::vector<std::vector<std::array<uint32_t, 3>>> pieces;  // each piece's closed boundary, boundary triangles first,
                                                             // oriented out of the piece
  std::vector<double> volumes;  // each piece's enclosed volume (of its oriented boundary): its tets must fill it
  size_t separator_triangles = 0;
  size_t separator_on_boundary = 0;  // of them, those with all three vertices on the boundary (no lattice point)
  size_t gap_triangles = 0;     // boundary triangles that are no Delaunay face of the cut's tetrahedralization
  int axis = 0;                 // the planes' normal (0: x, 1: y, 2: z)
  std::vector<double> planes;   // where they cut that axis
  std::string refused;          // not empty: why the material was not split (pieces and points are then empty)
};

// The tets TetGen makes (quality refinement, no volume bound) inside a closed boundary of `vertices` vertices that
// encloses `volume`, its triangles' mean edge length `mean_edge`: most grow along the boundary, fewer fill the inside
// (kTetsPerVertex, kTetsPerEdgeCube). Fitted on the 17 pieces of the paper-size head in 16 runs (tets 0.67-1.18 M):
// within 3.2% of every piece, against 23% for vertices alone. The cut places its planes and mesh_materials shares
// the runs among the materials by it.
double estimated_tets(double vertices, double volume, double mean_edge);

// The default `largest`: the plane-moving room of a material cut on its own.
constexpr double kLargestPiece = 1.25;

MaterialSplit split_material(const std::vector<glm::dvec3>& points, const std::vector<std::array<uint32_t, 3>>& boundary,
                             int pieces, uint32_t first_new, double largest = kLargestPiece);

}  // namespace cpmesh::mesh
