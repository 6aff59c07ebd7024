#pragma once
// The tetrahedral mesh of every material, bounded by the interface triangles and conforming to them.
//
// Each material is meshed on its own: one TetGen run (-pqAY, refining to the radius-edge bound only: the dihedral
// bound is the sliver passes' to hold) over the interface triangles that bound it, starting from points inside it as
// well (interior_points.h, computed here before the child starts: QualityOptions::interior_points), with the
// seeds of its components as regions and the seeds of every other material's components as holes (so cavities held
// by other materials are carved out, not meshed twice), then the sliver passes on its tets: those of smooth.h
// (improve_tets, split_slivers), then, for the slivers they leave, remesh_slivers.h (the cavity around each meshed
// afresh by TetGen). -Y puts no point on an input triangle, so two materials meet on exactly the interface
// triangles, as faces of tets on both sides, and the runs are independent: they go in parallel (the thread pool's
// limit, largest boundary first), each TetGen run in a child process because a failing TetGen can kill its process
// (child_process.h), its sliver passes back in this process (they use the thread pool, which a forked child of a
// multithreaded process must not). The runs are merged in material order.
// One TetGen run per material leaves cores idle where there are more cores than materials (the paper-size head: 4
// materials, the largest run 79 s of 87 on 16 cores). Asked for (QualityOptions::runs above 1, or 0: one per core),
// the runs are shared out one at a time to the material whose runs would be largest by the tets TetGen is estimated to
// make (split_material.h: estimated_tets), and a material given two or more is cut into
// pieces by planes (split_material.h), each piece a run bounded by its boundary triangles and the separators, which
// both sides keep (-Y); its region is the material (no seed: a component cut by a plane has one on one side only),
// less any region its boundary closes off from outside (drop_pockets). A piece whose tets do not fill the volume its
// boundary encloses, or a refused cut (split_material.h says when), meshes its material whole. The materials
// are cut first, all at once, then every run starts, largest first (each piece gets the points and its own
// material's separator points; the merge numbers the separators' points material by material). After the merge, where pieces were made, the sliver passes run once more with the
// separators' points free and only the interface triangles kept (a piece's own passes leave its cavities alone: its
// separators are kept there), on the part of the mesh around the tets under the bound (seam_passes). The result depends on the number of runs (with 0, on the thread limit), not otherwise on the thread
// count.
// A material whose boundary is not closed leaks into the outside when meshed alone; when any material fails, all
// are meshed in one run over every interface (its regions still labelled by the seeds), as before the split.
//
// Inputs:  points     the surface vertices (those no triangle uses are in no tet)
//          triangles  the interface triangles, pair[i] the two materials (indices) on either side of triangle i, its
//                     normal pointing out of pair[i][0] into pair[i][1] (extract.h)
//          seeds      a point inside every enclosed component, attribute = its material index + 1
//                     (component_representatives in extract.h)
//          labels     the materials' labels, for error messages
// Outputs: tets.points  `points` first, unchanged, then the separators' points of the materials meshed in pieces,
//                       then the points the runs added, run by run in material order, then where the seams' passes
//                       changed something the points of their part (those left unused go)
//          tets.tets, tets.region (the seed attribute: material + 1; 0 where a tet is in no seeded region)
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include <glm/glm.hpp>

#include "mesh/smooth.h"
#include "mesh/tetgen.h"

namespace cpmesh::mesh {

// Where one run's time went (seconds): TetGen (with its interior points' making), then the sliver passes
// (improve_tets, split_slivers).
struct MaterialRunTiming {
  uint16_t material = 0;  // index into labels; UINT16_MAX: the one run over all materials
  double tetgen = 0, slivers = 0;
  size_t tets = 0, added_points = 0;  // the points its tets have beyond the surfaces' (and the separators')
  uint16_t piece = 0, pieces = 1;  // of a material cut into pieces (split_material.h)
  size_t interior_points = 0;  // given to TetGen (interior_points.h): among added_points where it kept them
};

struct MaterialMeshes {
  Tets tets;
  std::vector<MaterialRunTiming> runs;  // one per run, in material order
  TetImproveReport improvement;  // smallest dihedral angles over all materials, moves summed
  SliverSplitReport sliver_split;
  std::string one_run_because;  // not empty: a material failed alone (why), so all were meshed in one run
  std::vector<std::string> unsplit_because;  // why a material asked to be cut was meshed whole, one line each
  size_t separator_points = 0;               // the lattice points the separators were made with (split_material.h)
  // Where the time went: cutting materials into pieces; the runs (TetGen and their sliver passes, in parallel, with
  // the whole-material reruns); merging, and the sliver passes over the seams where pieces were made (seam_passes).
  double cut_seconds = 0, runs_seconds = 0, seam_seconds = 0;
};

// Drops the tets of V's regions (V.region: TetGen's attributes, which number the regions no seed names) that lie
// outside the closed surface `boundary` (oriented outwards), by a vote over the tets' faces on it, and the points
// >= fixed they leave unused. A material's piece meshed without seeds uses it for pockets its boundary closes off.
void drop_pockets(Tets& V, const std::vector<std::array<uint32_t, 3>>& boundary, size_t fixed);

// The sliver passes of a run (improve_tets and split_slivers of smooth.h, remesh_slivers.h) over the part of T that
// they can change, for the seams of a mesh merged from pieces: the passes act only on tets under
// options.min_dihedral (moving their free vertices, refilling around them), so the part is those tets and three rings
// of tets around them through shared vertices. The part is meshed as its own Tets: its points that a tet outside it
// uses are fixed there, as are T's points < fixed, and its faces between points that outside tets use are kept (with
// the triangles `kept`), so no move, refill or cavity reaches past it. (The whole mesh's pass built its tables for every tet: on
// the paper-size head cut in 8 on this 2-core machine, 12.4 s for the merge and seams against 4.3 s.) The part's
// free points become new points of T after the others, T's points >= fixed that no tet uses then go, and the part's
// new tets follow the tets outside it. improvement.min_dihedral_after is over all of T, split.failed counts T's
// tets under the bound. Returns false, with T untouched, where no tet is under the bound.
bool seam_passes(Tets& T, size_t fixed, const std::vector<std::array<uint32_t, 3>>& kept, const QualityOptions& options,
                 TetImproveReport& improvement, SliverSplitReport& split);

// The estimated work of each material's TetGen run (estimated_tets, split_material.h) from the interface triangles
// that bound it: half as many vertices as triangles (a closed boundary), the volume they enclose (normals out of
// pair[i][0]), their mean edge length; 0 for a material no triangle bounds. Pair entries >= materials are skipped.
std::vector<double> material_work(const std::vector<glm::dvec3>& points, const std::vector<std::array<uint32_t, 3>>& triangles,
                                  const std::vector<std::array<uint16_t, 2>>& pair, size_t materials);

// How many runs each material gets, of `runs` asked for (mesh_materials): one each, then one at a time to the
// material whose runs would be largest by `work`, as long as its pieces keep min_piece_triangles of its `triangles`
// on average (at most 1024). Where every material can take them, the runs add up to `runs` and the largest run is as
// small as whole shares allow; with no more runs than materials, one each.
std::vector<int> share_runs(const std::vector<double>& work, const std::vector<size_t>& triangles, size_t runs,
                            size_t min_piece_triangles);

// Each tet's material index from V.region, for output: r - 1 where a seed named its region (1 <= r <= materials).
// A tet of any other region (TetGen numbers the regions no seed names, and has left a single tet of a named region
// at attribute 0 inside it: thin-128) takes the material across its faces that are no interface triangle, flooded
// from the named tets, since the tets on the two sides of such a face are of one material in a conforming mesh; a
// part with no named tet that interface triangles enclose takes the side of them it lies on (`triangles` oriented
// from pair[0] into pair[1]), by a vote over its faces on them; only a part with neither takes `fallback(t)` of its
// tets, by a vote.
std::vector<uint16_t> tet_materials(const Tets& V, const std::vector<std::array<uint32_t, 3>>& triangles,
                                    const std::vector<std::array<uint16_t, 2>>& pair, size_t materials,
                                    const std::function<uint16_t(uint32_t)>& fallback);

MaterialMeshes mesh_materials(const std::vector<glm::dvec3>& points, const std::vector<std::array<uint32_t, 3>>& triangles,
                              const std::vector<std::array<uint16_t, 2>>& pair, const std::vector<Region>& seeds,
                              const std::vector<uint16_t>& labels, const QualityOptions& options);

}  // namespace cpmesh::mesh
