#pragma once
// The last step of the guarantee (docs/design.md, "Mending by relabelling"): where the Delaunay refinement
// (refine.h) ends with faults left, the labels of the tets around them change. A fault is an interface edge in more
// than two triangles of its interface or in one off a triple curve (refine.h, nonmanifold_faces; its "excess": the
// triangles over two, or one), or a wrong face (extract.h, face_is_wrong). The refinement stalls where a sheet
// thins below what its samples resolve (thin-48's falx, a voxel thick, narrowing to a few tenths of a voxel under the
// skull): the tets between the sheet's two sides pinch it, two regions of one material touching along an edge only,
// and one-tet relabelling (repair_labels) cannot join them. Around an edge of a fault the tets form runs of one
// material each (joined through their faces that hold the edge); relabelling one run with a material across it joins
// the runs on its sides. A vertex of a wrong face that lacks one of the face's materials has its tets of materials it
// does not lie on relabelled together, with one it lies on. Of the candidates, the one kept removes the most faults
// over the edges and faces of its tets and adds none of either kind; of equals, the smallest in volume. Only labels
// change, so no triangle crosses another, every material stays closed and the tets still conform.
#include <cstdint>
#include <vector>

#include "fields/material_set.h"
#include "mesh/adjacency.h"
#include "mesh/tetgen.h"

namespace cpmesh::mesh {

struct TopologyMendReport {
  size_t edges = 0;       // edges of faults found before the first pass
  size_t relabelled = 0;  // tets relabelled
  size_t left = 0;        // edges of faults left
};

// vertex_kind: fields::FeatureKind per point (an interface edge in one triangle must end at junction vertices).
// Relabels `material` in place, at most `passes` sweeps over the edges of the faults.
TopologyMendReport mend_topology(const Tets& tets, const Adjacency& adj, const std::vector<uint16_t>& hull,
                                 const std::vector<fields::MaterialList>& vertex_materials,
                                 const std::vector<uint8_t>& vertex_kind, std::vector<uint16_t>& material,
                                 int passes = 10);

}  // namespace cpmesh::mesh
