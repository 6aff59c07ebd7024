#pragma once
// Critical configurations of a label map (docs/design.md, "Well-composed labels"): two voxels of one label that
// touch only along an edge (the other two voxels of their 2 x 2 square have other labels) or only at a corner (the
// other six of their 2 x 2 x 2 cube have other labels). The label map does not say there whether the label passes or
// is cut; the smoothed fields decide it at a saddle a fraction of a voxel across, which no sampling at the particles'
// spacing resolves. make_well_composed joins each such pair across a face by giving it one of the other voxels, so
// that the voxels of every label meet only across faces (a well-composed label map, Latecki 1997: every label's
// voxel boundary is a manifold).
#include <cstdint>
#include <vector>

#include "io/volume.h"

namespace cpmesh::mesh {

struct LabelChange {
  uint16_t label = 0;
  int64_t gained = 0, lost = 0;  // voxels
};

struct WellComposedReport {
  bool applied = false;         // the repair ran (MeshOptions::well_composed)
  int64_t critical_before = 0;  // critical configurations in the label map as given
  int64_t critical_left = 0;    // those no allowed change removes (a voxel changes once; islands keep theirs)
  int64_t voxels_changed = 0;
  int passes = 0;
  std::vector<LabelChange> labels;  // ascending by label: the labels that gained or lost voxels
};

// Edge-only pairs (one per 2 x 2 square and label) and corner-only pairs (one per cube diagonal) of `volume`.
int64_t critical_configurations(const io::LabelVolume& volume);

// A label gains at most this share of its voxels and loses at most as many: a sheet or shell one voxel thick steps
// diagonally almost everywhere (thin-48's one-voxel CSF shell had 693 such steps, 11.5% of its 6011 voxels), and
// joining them all would thicken it beyond the label volumes' tolerance. Its steps beyond that are left.
constexpr double kLabelChangeShare = 0.01;
// Labels under this many voxels give none: a small label is all staircase, and a voxel is a large part of it.
constexpr int64_t kProtectedLabelVoxels = 64;

// Removes the critical configurations of `volume` in place. For an edge-only pair of label L, one of the two other
// voxels of its square becomes L; where both diagonals of the square are pairs (a checkerboard), the label with fewer
// voxels in the 4 x 4 x 4 box around the square is the one joined, as it is the thin one (a sheet or a tube's wall
// stepping diagonally stays whole instead of being pierced). Of the two voxels, the one whose label is more common in
// that box gives. A corner-only pair takes one of the six other voxels of its cube, which leaves an edge-only pair
// for the next pass. A voxel changes at most once, never one with no face neighbour of its own label (an island of one
// voxel), never one of a label under `protected_voxels` voxels, and no label changes by more than `change_share` of
// its voxels (rounded up), so the passes end and the label volumes stay.
WellComposedReport make_well_composed(io::LabelVolume& volume, int64_t protected_voxels = kProtectedLabelVoxels,
                                      double change_share = kLabelChangeShare);

}  // namespace cpmesh::mesh
