#pragma once
// Interface extraction (seed paper Sec. 3.2, after BioMesh3D). The Delaunay tetrahedra of the settled particles are
// labelled with the material at their circumcentre (a Voronoi vertex of the particles), so a face is an interface
// face exactly when its dual Voronoi edge crosses an interface: the restricted Delaunay triangulation, whose
// triangles on a well-spread sampling are the surface's own, with no slivers through it. Faces on the convex hull
// take the material just outside them. The vertices are the particles themselves, so the interfaces share their
// vertices exactly along triple curves and at quadruple points.
//
// Repair: near triple curves a circumcentre can fall in a third material, giving an interface triangle with a vertex
// that does not lie on that interface (a particle of interface (a, b) in a triangle between a and c): the interface
// would then end away from its curve. repair_labels relabels such tets, one at a time, each with the material of a
// neighbour that leaves the fewest wrong faces around it, until no change helps; a face is right when each of its
// vertices lies on a feature bounding both of its materials. With no wrong face left, every interface's boundary
// lies on triple curves. Boundaries between labelled tet regions are closed by construction.
#include <array>
#include <cstdint>
#include <vector>

#include "fields/indicator_fields.h"
#include "fields/material_set.h"
#include "mesh/adjacency.h"
#include "mesh/tetgen.h"

namespace cpmesh::mesh {

struct InterfaceMesh {
  std::vector<glm::dvec3> vertices;                // local coordinates (the particles)
  std::vector<uint8_t> vertex_kind;                // fields::FeatureKind of the particle
  std::vector<std::array<uint32_t, 3>> triangles;  // oriented: the normal points from pair[0] into pair[1]
  std::vector<std::array<uint16_t, 2>> pair;       // material indices (IndicatorFields::labels), pair[0] < pair[1]
  std::vector<uint32_t> face;                      // the tet face of each triangle (tet * 4 + corner); kNoFace
                                                   // once flipped (interface_flips.h)
};

// The face of tet tc / 4 opposite corner tc % 4, ordered so its normal points out of the tet.
std::array<uint32_t, 3> outward_face(const Tets& tets, uint32_t tc);

glm::dvec3 circumcentre(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d, bool& ok);
// Where a tet's material is read: its circumcentre (its centroid when flat).
glm::dvec3 label_point(const Tets& tets, uint32_t t);
// Where the material outside hull face tc is read (see hull_materials).
glm::dvec3 hull_sample_point(const fields::IndicatorFields& fields, const Tets& tets, uint32_t tc);
// Material index of tet t at its circumcentre (clamped to the grid; a flat tet uses its centroid), and of every tet.
uint16_t label_tet(const fields::IndicatorFields& fields, const Tets& tets, uint32_t t);
std::vector<uint16_t> label_tets(const fields::IndicatorFields& fields, const Tets& tets);
// Per hull face (indexed like Adjacency::neighbour): the material outside it, sampled half a voxel plus the face's
// circumradius (at most 4 voxels) out, beyond any surface its corners sample; 0 for inner faces.
std::vector<uint16_t> hull_materials(const fields::IndicatorFields& fields, const Tets& tets, const Adjacency& adj);

// The material across face tc (tet * 4 + corner): the neighbour tet's, or the hull material outside.
uint16_t material_across(const Adjacency& adj, const std::vector<uint16_t>& hull, const std::vector<uint16_t>& material,
                         uint32_t tc);
// vertex_materials[v]: the materials of the feature particle v lies on (Feature::material_set).
// Face tc between materials m and o is wrong when m != o and one of its vertices lacks m or o.
bool face_is_wrong(const Tets& tets, uint32_t tc, uint16_t m, uint16_t o, const std::vector<fields::MaterialList>& vertex_materials);
// Returns the number of tets relabelled.
size_t repair_labels(const Tets& tets, const Adjacency& adj, const std::vector<uint16_t>& hull,
                     const std::vector<fields::MaterialList>& vertex_materials, std::vector<uint16_t>& material, int passes = 50);
// The wrong faces (as tet * 4 + corner, each shared face once).
std::vector<uint32_t> wrong_faces(const Tets& tets, const Adjacency& adj, const std::vector<uint16_t>& hull,
                                  const std::vector<fields::MaterialList>& vertex_materials, const std::vector<uint16_t>& material);

InterfaceMesh extract_interfaces(const Tets& tets, const Adjacency& adj, const std::vector<uint16_t>& hull,
                                 const std::vector<uint16_t>& material, const std::vector<uint8_t>& vertex_kind);

// A vertex whose triangles meet more materials than its feature has, all of them in its (widened) material set
// (refine.h, widen_to_near_junctions), is a junction of the mesh: its kind becomes that of the junction (a triple
// curve for three materials, a quadruple point for four or more: a junction point) in `kind` and in
// mesh.vertex_kind. Returns how many.
size_t promote_junction_vertices(InterfaceMesh& mesh, const std::vector<fields::MaterialList>& vertex_materials,
                                 std::vector<uint8_t>& kind);

// Hull face tc with its own tet's material beyond it: no interface closes that tet's region from the outside.
inline bool opens_to_outside(const Adjacency& adj, const std::vector<uint16_t>& hull,
                             const std::vector<uint16_t>& material, uint32_t tc) {
  return adj.neighbour[tc] == Adjacency::kHull && material_across(adj, hull, material, tc) == material[tc / 4];
}
// One tet per connected set of same-material tets (through shared faces) that is enclosed by interfaces: the
// one with the largest inscribed sphere (its centroid seeds the region in the volume mesh).
std::vector<uint32_t> component_representatives(const Tets& tets, const Adjacency& adj, const std::vector<uint16_t>& hull,
                                                const std::vector<uint16_t>& material);

}  // namespace cpmesh::mesh
