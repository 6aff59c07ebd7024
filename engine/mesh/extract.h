#pragma once
// Interface extraction (seed paper Sec. 3.2, after BioMesh3D): the Delaunay tetrahedra of the settled particles are
// labelled with the material at their circumcentre (argmax of the indicator fields), and every face between two tets of
// different materials, or between a tet and the outside of the convex hull where another material lies, becomes an
// interface triangle. The vertices are the particles themselves, so the interfaces share their vertices exactly along
// triple curves and at quadruple points.
#include <array>
#include <cstdint>
#include <vector>

#include "fields/indicator_fields.h"
#include "mesh/tetgen.h"

namespace cpmesh::mesh {

struct InterfaceMesh {
  std::vector<glm::dvec3> vertices;                // local coordinates (the particles)
  std::vector<uint8_t> vertex_kind;                // fields::FeatureKind of the particle
  std::vector<std::array<uint32_t, 3>> triangles;  // oriented: the normal points from pair[0] into pair[1]
  std::vector<std::array<uint16_t, 2>> pair;       // material indices (IndicatorFields::labels), pair[0] < pair[1]
};

// Material index of every tet, at its circumcentre (a Voronoi vertex of the particles): a face is then an interface
// face exactly when its dual Voronoi edge crosses an interface, the restricted Delaunay triangulation, whose
// triangles on a well-spread sampling are the surface's own (no slivers through it). Circumcentres beyond the grid
// are clamped to it; a flat tet uses its centroid.
glm::dvec3 circumcentre(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d, bool& ok);
std::vector<uint16_t> label_tets(const fields::IndicatorFields& fields, const Tets& tets);

InterfaceMesh extract_interfaces(const fields::IndicatorFields& fields, const Tets& tets,
                                 const std::vector<uint16_t>& tet_material, const std::vector<uint8_t>& vertex_kind);

}  // namespace cpmesh::mesh
