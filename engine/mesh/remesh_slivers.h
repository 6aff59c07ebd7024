#pragma once
// The last sliver pass: the slivers that moving vertices (improve_tets) and one-vertex refills (split_slivers) leave
// are cut out with the tets around them and each cavity is meshed afresh by TetGen (-pqAY over the cavity's boundary
// faces, which stay as they are, with TetGen's dihedral bound, which the material runs leave to the passes). It mends what the
// other passes cannot: a tet whose four vertices all lie on kept interface triangles needs new vertices placed
// together, and a material meshed in pieces (volume_mesh.h) leaves such tets along its separators, where each piece
// had to keep the other's faces; after the merge the separator is an inner surface like any other.
//
// A cavity: the bad tet, the tets sharing a vertex with it and reachable across faces, then `rings` rings of face
// neighbours; always within the bad tet's region and never across a face in `kept` (the interface triangles).
// Overlapping cavities are merged; a merged cavity that would drop a vertex below `fixed` or hold a kept face between
// two of its tets is left alone. All cavities go to one TetGen run in a child process (child_process.h), one region
// seed each (the centroid of its best-shaped tet; `batch` > 0: that many per run); where TetGen gives up, the cavities
// are halved and tried again, down to single ones. A cavity's new tets must have exactly its boundary faces as their
// own; their new points are then moved as improve_tets moves (the old tets had that pass too), and they replace the old
// tets only when they fill the same volume (1e-9), raise the cavity's smallest dihedral angle and leave no more tets
// below the bound. The inner vertices of a remeshed cavity are gone: where any cavity was remeshed, points >= `fixed`
// that no tet uses are removed and the later ones renumbered (points below `fixed` never move or go).
// Deterministic.
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include <glm/glm.hpp>

#include "mesh/tetgen.h"

namespace cpmesh::mesh {

struct SliverRemeshReport {
  size_t slivers = 0;    // tets below the dihedral bound on entry
  size_t cavities = 0;   // after merging
  size_t remeshed = 0;   // cavities replaced by their new mesh
  size_t tetgen_failures = 0;  // runs TetGen gave up on (then halved)
  size_t points_removed = 0;
};

// Removes the points >= fixed that no tet uses, numbering the later ones down; returns how many.
size_t remove_unused_points(std::vector<glm::dvec3>& points, std::vector<std::array<uint32_t, 4>>& tets, size_t fixed);

// before_run (tests): called with each TetGen run's cavity count before the run; an exception it throws counts as
// TetGen giving up on that run.
SliverRemeshReport remesh_slivers(std::vector<glm::dvec3>& points, std::vector<std::array<uint32_t, 4>>& tets,
                                  std::vector<int>& region, const std::vector<std::array<uint32_t, 3>>& kept,
                                  size_t fixed, const QualityOptions& options, int rings = 3, size_t batch = 0,
                                  const std::function<void(size_t cavities)>& before_run = nullptr);

}  // namespace cpmesh::mesh
