#pragma once
// Delaunay refinement of the restricted Delaunay triangulation (docs/design.md, "The guarantee"). The particles are a
// good sample, but where one is too sparse for the surface's shape (a thin sheet, a junction of many labels, a
// staircase), the interface triangles of the particles' Delaunay do not have the surface's topology: a face between
// materials m and o has a vertex on no feature of m and o (a wrong face), or an interface edge lies in more than two
// of its triangles, or ends away from a triple curve. As CGAL Mesh_3 refines a facet whose vertices are not on its
// own patch, curve or an incident corner, each such place gets a new sample on the feature it is missing: the
// closest point, to the place, of the feature of m and o (their interface, or a triple curve or quadruple point of m,
// o and the materials of the place's vertices) that lies nearest; the Delaunay takes the points and the faces are
// labelled again. A vertex on the wrong feature where a sample is due moves there; other samples nearer than the
// crowding radius to a vertex or to another new sample are not added, so a round that finds no room adds nothing and
// the refinement ends. The crowding radius is kCrowding x h; around a face whose vertices are all on the right
// features but whose edges are not manifold it is less where the face is smaller than that: half its surface
// Delaunay ball's radius (which no point lies within), so a thin sheet or a tube's wall sampled too sparsely for its
// thickness gets samples closer than h, as Delaunay refinement shrinks the balls until the topology is right
// (kMinCrowding voxels bounds it from below). A wrong face keeps kCrowding x h: what it lacks is a junction sample,
// and interface samples squeezed in beside the junction only make more wrong faces (the 40^3 wedge ball without
// junction protection: 84 wrong faces left instead of none).
#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "fields/closest_point_embedding.h"
#include "mesh/adjacency.h"
#include "mesh/extract.h"
#include "mesh/tetgen.h"

namespace cpmesh::mesh {

// A sample to insert: local coordinates, its feature (an index into the embedding's features) and sizing h there.
struct RefinePoint {
  glm::dvec3 position;
  uint32_t feature;
  float h;
};

constexpr double kCrowding = 0.3;
constexpr double kBallShare = 0.5;
constexpr double kMinCrowding = 0.05;  // voxels

// A place that needs a sample: where it is (local coordinates), the two materials (indices) of the face or edge,
// and the materials its vertices lie on (the union of their features' material sets, ascending).
struct RefineSite {
  glm::dvec3 at;
  uint16_t m, o;
  std::vector<uint16_t> vertex_materials;
  std::array<uint32_t, 3> vertices;  // the face's
  double radius;                     // from `at` to the face's nearest vertex: its surface Delaunay ball's radius
  bool wrong;                        // a vertex lacks m or o (face_is_wrong), rather than an edge not manifold
};

// Sites of tet faces (tet * 4 + corner): per face, where its dual Voronoi edge (from the label point of its tet to
// that of the tet across, or to the hull's sample point outside) leaves the face's first material, found on the
// indicator fields by bisection: the centre of the face's surface Delaunay ball, as Delaunay refinement inserts
// (the face centroid where the edge shows no change of material).
std::vector<RefineSite> face_sites(const fields::IndicatorFields& fields, const Tets& tets, const Adjacency& adj,
                                   const std::vector<uint16_t>& hull, const std::vector<uint16_t>& material,
                                   const std::vector<fields::MaterialList>& vertex_materials, const std::vector<uint32_t>& faces);

// The tet faces of the interface triangles around edges where an interface is not an edge-manifold bounded by
// triple curves: edges in more than two triangles of one interface, and edges in one triangle of an interface that
// fewer than three interface triangles share or that end at an interface vertex.
std::vector<uint32_t> nonmanifold_faces(const InterfaceMesh& mesh);

// The tet faces of the interface triangles around triple-curve and quadruple-point vertices where an interface's
// triangles form more than one fan (pinched at the vertex: its edges may all be manifold). Not part of the guarantee
// (which asks for edge-manifold interfaces), but there a sample short of the junctions' shape, refined as a
// non-manifold edge is. An interface vertex's pinch is left: it is where a thin sheet's two sides meet in the
// fields themselves, which samples cannot part (docs/design.md, "Delaunay refinement").
std::vector<uint32_t> pinched_vertex_faces(const InterfaceMesh& mesh);

// The faults of an interface edge with `in_interface` triangles of one interface and `around` interface triangles of
// all interfaces: the triangles over two, or one for a single triangle off a triple curve (fewer than three
// interface triangles around it, or an end that is not a junction vertex). nonmanifold_faces reports the faces of
// edges with any; mend_topology.h lowers their sum.
inline int edge_excess(size_t in_interface, size_t around, bool ends_on_junctions) {
  if (in_interface > 2) return int(in_interface - 2);
  return in_interface == 1 && (around < 3 || !ends_on_junctions);
}

// New samples for the sites: per site the closest point of a candidate feature (from the embedding, or by Newton on
// the fields where the embedding's stencil is incomplete, as at a thin part's edge; h is then the smallest of the
// face's vertices'): a triple curve or quadruple point whose closest point lies within `protection` x h (the
// junction protection's distance), else the nearest. A sample within the crowding radius of a point that lies on no
// feature of the site's two materials moves that point there (it was on the wrong feature). Where a point on a right
// feature is in the way, the face's vertices that lack one of the two materials move instead, each to the closest
// point of the feature of its own materials and the two (a junction it lies next to) within h of it where that has
// room, or are removed (as the junction protection leaves out interface particles beside a junction). Points in
// `fixed` (moved in earlier rounds) are removed rather than moved again. Samples near a sample chosen before them
// are dropped.
struct Refinement {
  std::vector<RefinePoint> added;
  std::vector<std::pair<uint32_t, RefinePoint>> moved;  // point index, where it goes and its new feature
  std::vector<uint32_t> removed;                         // points on a wrong feature with no junction to go to
};
struct RefineVertices {
  const std::vector<glm::dvec3>& points;
  const std::vector<fields::MaterialList>& materials;
  const std::vector<float>& h;
  const std::vector<uint8_t>& fixed;
};
Refinement refinement_points(const fields::IndicatorFields& fields, const fields::ClosestPointEmbedding& embedding,
                             const std::vector<RefineSite>& sites, const RefineVertices& vertices, double protection);

// How near two junctions are one for the mesh: kCrowding x h (the refinement places no sample nearer), at least
// kMinCrowding and at most kJunctionReach voxels, below the label map's own resolution (at 0.3 h alone, where h is
// several voxels, parcellation-300-32 got a junction vertex of label 0 with no voxel of 0 within a voxel of it).
constexpr double kJunctionReach = 0.5;  // voxels
inline double junction_radius(float h, double voxel) {
  return std::clamp(kCrowding * double(h), kMinCrowding * voxel, kJunctionReach * voxel);
}

// The quadruple points (and curve points) to leave out: each within junction_radius of one before it. Where five
// to eight labels meet around a voxel corner the smoothed fields have a cluster of quadruple points a
// ten-thousandth to a few tenths of a voxel apart, which no sampling at the crowding radius separates: as vertices
// they make a tangle of slivers and non-manifold edges. The first of a cluster stands for it
// (widen_to_near_junctions gives it the others' materials). Curve points as near to a kept quadruple point go too,
// as the junction protection clears interface points from around curves. Other points are left alone.
std::vector<uint32_t> clustered_junction_points(const std::vector<glm::dvec3>& points, const std::vector<uint8_t>& kind,
                                                const std::vector<float>& h, double voxel);

// Junctions closer than the refinement can separate (docs/design.md, "Junctions closer than the crowding radius"):
// where four labels meet along a voxel edge (a 2 x 2 staircase), the smoothed fields split the line into two triple
// curves a few hundredths of a voxel apart, joined by a ribbon of interface between two of the four that no
// sampling at the crowding radius resolves. A junction vertex (on a curve or point: an interface vertex beside a
// junction is the refinement's, which moves it onto the junction) of a wrong face that lacks the face's materials
// is taken to lie on them when a triple curve or quadruple point of its own materials and the face's (at most
// kMaxJunctionMaterials in all, the labels around a voxel corner) has its closest point within junction_radius of it:
// its material set grows by that feature's. Returns how many sets grew.
constexpr size_t kMaxJunctionMaterials = 8;
size_t widen_to_near_junctions(const fields::IndicatorFields& fields, const fields::ClosestPointEmbedding& embedding,
                               const Tets& tets, const Adjacency& adj,
                               const std::vector<uint16_t>& hull, const std::vector<uint16_t>& material,
                               const std::vector<uint32_t>& wrong, const std::vector<float>& h,
                               std::vector<fields::MaterialList>& vertex_materials);

// The last resort where faults are left after the refinement and the mend (docs/design.md, "Mending by
// relabelling"): an interface vertex of a wrong face that lacks the face's materials, where the refinement could not
// move it onto their junction for the junction vertices already around it (the tip of a tube a voxel thick ending on
// a sheet), joins it where it stands: the triple curve (or quadruple point) of its two materials and the missing
// ones, where its closest point lies within kJunctionReach voxels. Returns each such vertex once, with that feature
// and closest point. The mesher gives the vertex the feature and leaves it in place (moved onto the curve at once, on
// thin-128 it landed 0.013 voxel from a vertex of the sheet: 8 tets under 10 degrees there); the smoothing moves
// it along and onto the curve where its triangles allow.
std::vector<std::pair<uint32_t, RefinePoint>> wrong_vertex_junctions(const fields::IndicatorFields& fields,
                                                             const fields::ClosestPointEmbedding& embedding,
                                                             const Tets& tets, const Adjacency& adj,
                                                             const std::vector<uint16_t>& hull,
                                                             const std::vector<uint16_t>& material,
                                                             const std::vector<uint32_t>& wrong, const std::vector<float>& h,
                                                             const std::vector<fields::MaterialList>& vertex_materials);

}  // namespace cpmesh::mesh
