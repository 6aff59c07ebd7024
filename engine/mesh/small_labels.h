#pragma once
// Labels too small to mesh as regions of their own (docs/design.md, "Labels"): a label with fewer than
// MeshOptions::min_label_voxels voxels joins the label its voxels touch most across voxel faces (the outside, label 0,
// when they touch nothing else), and the report lists it with its voxel count and where it went. Labels are data:
// none vanishes unreported.
#include <cstdint>
#include <vector>

#include "io/volume.h"

namespace cpmesh::mesh {

struct DroppedLabel {
  uint16_t label = 0;
  int64_t voxels = 0;
  uint16_t merged_into = 0;
};

// Voxels per label value (65536 entries): counted once, for the small-label rule and the material limit
// (check_label_limit in pipeline.h).
using LabelCensus = std::vector<int64_t>;
LabelCensus label_census(const io::LabelVolume& volume);

// The labels of `volume` (counted in `census`) with fewer than min_voxels voxels (ascending by label) and the label
// each joins; none when min_voxels <= 1. A small label does not join another small label while a kept one touches it.
std::vector<DroppedLabel> small_labels(const io::LabelVolume& volume, const LabelCensus& census, int64_t min_voxels);
inline std::vector<DroppedLabel> small_labels(const io::LabelVolume& volume, int64_t min_voxels) {
  return small_labels(volume, label_census(volume), min_voxels);
}
// `volume` with each dropped label replaced by the label it joins, and its census the same way.
io::LabelVolume merge_labels(const io::LabelVolume& volume, const std::vector<DroppedLabel>& dropped);
LabelCensus merge_labels(LabelCensus census, const std::vector<DroppedLabel>& dropped);

}  // namespace cpmesh::mesh
