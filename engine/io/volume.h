#pragma once
// Volumes in physical units: voxel (i, j, k)'s centre lies at origin + (i, j, k) * spacing (axis-aligned; readers apply
// axis permutations and flips of the file's direction matrix and refuse oblique ones). Samples are stored x fastest:
// index = (k * dims[1] + j) * dims[0] + i.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "io/scalar_type.h"

namespace cpmesh::io {

struct VolumeGeometry {
  std::array<int64_t, 3> dims{0, 0, 0};
  std::array<double, 3> spacing{1, 1, 1};
  std::array<double, 3> origin{0, 0, 0};

  int64_t voxel_count() const { return dims[0] * dims[1] * dims[2]; }
  size_t index(int64_t i, int64_t j, int64_t k) const { return size_t((k * dims[1] + j) * dims[0] + i); }
  std::array<double, 3> position(int64_t i, int64_t j, int64_t k) const {
    return {origin[0] + double(i) * spacing[0], origin[1] + double(j) * spacing[1], origin[2] + double(k) * spacing[2]};
  }
};

struct LabelVolume : VolumeGeometry {
  std::vector<uint16_t> labels;
  ScalarType file_type = ScalarType::u16;  // the sample type the file stored (for `cpmesh info`)
  std::string format;                      // "NRRD", "MetaImage", "NIfTI-1", "INRIMAGE", "raw"
  std::string source;                      // the path it was read from
};

// A scalar field (distance, sizing, ...) dumped for inspection.
struct FloatVolume : VolumeGeometry {
  std::vector<float> values;
  std::string source;
};

}  // namespace cpmesh::io
