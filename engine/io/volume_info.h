#pragma once
// What `cpmesh info` reports about a labeled volume: geometry, and per label its voxel count, bounding box and the
// labels it touches across a voxel face (6-connectivity).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "io/volume.h"

namespace cpmesh::io {

struct LabelInfo {
  uint16_t label = 0;
  int64_t voxels = 0;
  std::array<int64_t, 3> min_voxel{}, max_voxel{};  // inclusive voxel index bounds
  std::array<double, 3> min_physical{}, max_physical{};  // the box covered by those voxels (centres +- spacing / 2)
  std::vector<uint16_t> neighbours;                       // ascending
};

struct VolumeInfo {
  VolumeGeometry geometry;
  std::string format, source, type;
  std::vector<LabelInfo> labels;  // ascending by label
};

VolumeInfo summarize(const LabelVolume& v);
// Human-readable report; labels with fewer than `few_voxels` voxels get a warning line.
std::string format_volume_info(const VolumeInfo& info, int64_t few_voxels = 64);

}  // namespace cpmesh::io
