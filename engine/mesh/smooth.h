#pragma once
// Smoothing of the interface meshes after extraction: the restricted Delaunay triangles of a relaxed particle
// system are good where the particles are evenly spread, but graded sizing and the junctions leave a tail of
// flattened triangles, most of them at the junctions. Each round moves every vertex towards a shape target, the mean
// of the points that would make each of its triangles equilateral: an interface vertex in its surface (the triangles
// along triple curves need it: the area-weighted centroid of a one-sided star is about where the vertex is), a
// triple-curve vertex along its curve (the target's shift from its curve neighbours' midpoint, or that midpoint,
// whichever does better). It puts the vertex back on its feature with the Newton projection of the smooth fields (the
// embedding's own construction) and keeps the move only if none of its triangles flips and the worst radius ratio
// among them does not get worse, or stays at least SmoothOptions::kShapeFloor while their sum grows ("smart"
// smoothing; docs/design.md, "Interface smoothing"), checked against the moves already kept: vertex by vertex within
// a colour class (no two vertices of one triangle share a colour, so a class is checked in parallel), class by
// class. Where triangles cross others (thin layers), their moved vertices go back to the last positions tested
// crossing-free: the test runs after every round while it finds crossings, else once after the last round.
// Quadruple points do not move. Connectivity is unchanged, so the interfaces stay conforming along the curves and
// manifold where they were.
#include <array>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "fields/closest_point_embedding.h"
#include "mesh/extract.h"

namespace cpmesh::mesh {

struct SmoothOptions {
  int rounds = 10;      // 0: off
  double step = 0.8;    // share of the way to the target per round
  // A move may make the worst triangle around its vertex worse only while that stays at least this radius ratio.
  static constexpr double kShapeFloor = 0.3;
};

struct SmoothReport {
  int rounds = 0;
  size_t moves = 0;     // accepted vertex moves, all rounds
  size_t refused = 0;   // moves undone (a flip, a worse triangle, or a projection that did not converge)
};

// `near` put on embedding feature `feature` of the smooth fields: the embedding's closest point where its lookup is
// valid there, else the Newton projection started from `start` (a point on the feature). False where neither gives one.
bool onto_feature(const fields::IndicatorFields& fields, const fields::ClosestPointEmbedding& embedding, uint32_t feature,
                  const glm::dvec3& near, const glm::dvec3& start, glm::dvec3& on);

// vertex_feature[v]: the embedding feature of vertex v (interface, triple curve or quadruple point).
SmoothReport smooth_interfaces(const fields::IndicatorFields& fields, const fields::ClosestPointEmbedding& embedding,
                               const std::vector<uint32_t>& vertex_feature, InterfaceMesh& mesh,
                               const SmoothOptions& options = {});

// Moves checked one vertex at a time cannot see the rest of the mesh: where a layer is thinner than the triangles
// are wide (a one-voxel shell), a vertex pulled towards its neighbours' centroid can push its triangles through
// the other side's. Undoes, back to `start` (crossing-free positions), every moved vertex of two
// crossing triangles, then every moved vertex of a triangle that the undoing flipped against its start, until
// neither is left. Returns how many moves were undone.
size_t undo_crossings(const std::vector<glm::dvec3>& start, const std::vector<std::array<uint32_t, 3>>& T,
                      std::vector<glm::dvec3>& V);

// Sliver removal in a volume mesh by moving its free vertices: TetGen refines the materials to the radius-edge bound
// only (QualityOptions::dihedral_in_tetgen), which leaves about 1.6% of the tets under 12 degrees, and with the
// interface triangles kept (no Steiner points on them) only the inner vertices can move.
// Each pass visits the vertices >= `fixed` of every tet whose smallest dihedral angle is below target_deg and tries
// the centroid of its neighbours and shrinking random steps, keeping the position that most raises the smallest
// dihedral angle of its tets without inverting any or taking one over the radius-edge bound (or over its own
// ratio where that is higher). The vertices move in rounds, on every core: a round moves each waiting one that comes
// before every other waiting one it shares a tet with (in tet order, then the order they were added), so movers
// never share a tet; a moved vertex's tets still below the target send their free vertices back (at most three
// visits each in a pass). Its random steps are a hash of the pass, the visit and the vertex. Deterministic, the
// same on any thread count. Returns the smallest dihedral angle before and after.
// (It was one vertex at a time in tet order, with one random stream. Material 4 of the paper-size head, 1.74 M tets
// from TetGen, 2 threads: 2.35-2.73 -> 1.01 s, 49,894 -> 29,053 moves, the smallest angle 5.54 -> 8.36 degrees
// either way, 78 against 87 tets left under 12 degrees, which split_slivers then mended in both. head:160 in 16
// runs: the runs' passes 13.2 -> 10.3 s in sum, 2 tets under 12 degrees left either way; the 48^3 shells: 6,183
// against 6,176 left, the same thin-layer slivers.)
struct TetImproveReport {
  double min_dihedral_before = 0, min_dihedral_after = 0;  // degrees
  size_t moves = 0;
};
TetImproveReport improve_tets(std::vector<glm::dvec3>& points, const std::vector<std::array<uint32_t, 4>>& tets,
                              size_t fixed, double target_deg = 12.0, double max_radius_edge = 1.5, int passes = 4);
// The standard normal improve_tets takes for random-step key `key` (two hashed uniforms, Box-Muller).
double hashed_normal(uint64_t key);

// Slivers that moving vertices cannot fix: a tet whose four vertices are all kept surface vertices (two interface
// triangles folded a few degrees across their shared edge, with the flat tet filling the fold; or four vertices of
// a thin part's boundary, such as a wedge's tip) keeps its shape whatever the inner vertices do. For each tet whose
// smallest dihedral angle is below target_deg:
//  1. Edge removal (remove_edges): the n tets (3 to 7) around one of its edges, all of one region and with no kept
//     face on the edge, become the 2n - 4 tets joining the edge's ends to a fan triangulation of the ring of their
//     other vertices. A sliver's two long edges carry its near-180-degree angles, so removing one removes it with no
//     new vertex. The best edge and fan is taken if it beats the old tets' smallest angle.
//  2. Otherwise the tet is cut out together with its neighbours of the same region (never across a face in `kept`,
//     the interface triangles) and the cavity is filled again by joining its boundary faces to one new inner vertex,
//     placed where the smallest dihedral angle of the new tets is largest. The cavity grows by rings (at most
//     `max_rings`) until a position improves on the old tets' smallest angle.
// Neither makes a tet over 1.5 times the radius-edge bound (or the old tets' largest ratio). No kept face changes, no
// kept vertex is dropped, the volume is preserved; new points are appended to `points` and take the cavity's region.
// Deterministic. Edge removal took the 48^3 wedge ball's worst tet (9.2 degrees, four vertices on a wedge's tip,
// where no new vertex found a better place) to the 12-degree bound.
struct SliverSplitReport {
  size_t flips = 0;     // edges removed (no new vertex)
  size_t inserted = 0;  // new inner vertices
  size_t failed = 0;    // slivers neither could improve (volume_mesh.cpp: tets left below the bound after all passes)
  size_t remeshed = 0;  // cavities meshed afresh after these passes (remesh_slivers.h; set by volume_mesh.cpp)
};
SliverSplitReport split_slivers(std::vector<glm::dvec3>& points, std::vector<std::array<uint32_t, 4>>& tets,
                                std::vector<int>& region, const std::vector<std::array<uint32_t, 3>>& kept,
                                double target_deg = 12.0, double max_radius_edge = 1.5, int max_rings = 3,
                                bool remove_edges = true);

}  // namespace cpmesh::mesh
