#pragma once
// Label volumes (docs/design.md, "Label volumes"): the interfaces' vertices lie on the smooth fields' surfaces and
// their triangles are chords of them, so a label thin across its curvature loses volume twice: the antialiasing
// rounds it (a 3 x 3 voxel tube's fields enclose 3.6% less than its voxels) and the chords cut it (another 2.5% at
// 15 triangles around). Last, on the final vertices (after the volume mesh and its sliver moves, where there is
// one), each bounded label whose interfaces enclose more than `tolerance` more or less than its voxels grows or
// shrinks along its vertex normals by the same distance everywhere until they do; a vertex of one interface moves by
// the difference of its two sides' distances, and by at most a quarter of its shortest edge. Junction vertices
// (curves, points, and vertices promoted to them) stay, and so do the triple curves. With a volume mesh, a move that
// turns a tet over or takes one below the dihedral bound (or below its own angle) is refused, so the tets keep their
// quality and stay on the interfaces; moves that make triangles cross or flip (on the outer boundary, where a star is
// half a ball) are undone as the smoothing's are (smooth.h undo_crossings).
#include <cstdint>
#include <vector>

#include "mesh/elements_around.h"
#include "mesh/extract.h"

namespace cpmesh::mesh {

struct LabelVolumeOptions {
  double tolerance = 0.01;  // share of a label's voxel volume (0: off)
  double max_move = 0.25;   // voxels of the smallest spacing: no label grows or shrinks by more
  int rounds = 4;           // measure-and-move rounds (the fixed junction vertices make each round fall short)
  uint64_t min_voxels = 65;  // smaller labels are islands (fields/indicator_fields.h island_voxels), kept as they are
};

struct LabelVolumeReport {
  size_t labels_moved = 0;
  size_t moves_undone = 0;   // for a crossing or a flipped triangle
  size_t moves_refused = 0;  // for a tet turned over or taken below the dihedral bound (or below its own angle)
  // Largest |enclosed - voxel volume| / voxel volume over the bounded labels of at least min_voxels, and its label.
  double worst_before = 0, worst_after = 0;
  int worst_material = -1;  // index into the labels, after; -1: none measured
  int worst_label = -1;     // its label value (set by the pipeline)
};

// The volume each material's interface triangles enclose, by the divergence theorem (triangles oriented from pair[0]
// into pair[1]); meaningful only for a material they close.
std::vector<double> enclosed_volumes(const InterfaceMesh& mesh, size_t materials);
// Per material: 1 where its triangles use every edge an even number of times (an XOR of hashed edges: an odd edge
// is missed with probability 2^-64).
std::vector<uint8_t> closed_materials(const InterfaceMesh& mesh, size_t materials);

// The volume mesh the interface vertices are the first points of, where there is one: a move is kept only where the
// tets around its vertex allow it (none turns over; min_dihedral_deg below), and goes into both meshes.
struct TetsAround {
  std::vector<glm::dvec3>* points = nullptr;  // null: no volume mesh
  const std::vector<std::array<uint32_t, 4>>* tets = nullptr;
  const ElementsAround<4>* around = nullptr;
  double min_dihedral_deg = 12;  // a move keeps every tet around its vertex at this angle, or at its own if less
};

// target[m]: material m's voxel volume; measured[m]: 0 where m is open to the outside of the mesh (its region reaches
// the hull) or is too small (min_voxels), so that nothing moves it. kind: the vertices' fields::FeatureKind after
// promotion to junctions.
LabelVolumeReport match_label_volumes(InterfaceMesh& mesh, const std::vector<uint8_t>& kind,
                                      const std::vector<double>& target, const std::vector<uint8_t>& measured,
                                      double voxel_size, const LabelVolumeOptions& options = {},
                                      const TetsAround& volume_mesh = {});

}  // namespace cpmesh::mesh
