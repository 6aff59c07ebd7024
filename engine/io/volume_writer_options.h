#pragma once
// Options shared by the volume writers, and the sample encoding they share.
#include <optional>
#include <string>

#include "io/volume.h"

namespace cpmesh::io {

struct VolumeWriteOptions {
  std::optional<ScalarType> type;  // default: uint8 when every label fits, else uint16 (float32 for FloatVolume)
  bool big_endian = false;
  bool compress = false;           // gzip (NRRD, .nii.gz, .inr.gz) or zlib (MetaImage CompressedData)
};

ScalarType label_write_type(const LabelVolume& v, const VolumeWriteOptions& o);
// Samples as bytes; throws Error naming `path` when a label does not fit `type`.
std::string encode_labels(const LabelVolume& v, ScalarType type, bool big_endian, const std::string& path);
std::string encode_floats(const FloatVolume& v, ScalarType type, bool big_endian, const std::string& path);

}  // namespace cpmesh::io
