#pragma once
// Reading a labeled volume (or a float field) from any supported file. The format comes from the content: NRRD,
// NIfTI-1, MetaImage and INRIMAGE headers are recognised by their first bytes, and a gzip-compressed file (.nii.gz,
// .inr.gz) is inflated and recognised again. Only a file without a recognised header is read as headerless raw, and
// only when RawOptions describe it.
#include <array>
#include <cstdint>
#include <string>

#include "io/volume.h"

namespace cpmesh::io {

struct RawOptions {
  std::array<int64_t, 3> dims{0, 0, 0};
  std::array<double, 3> spacing{1, 1, 1};
  std::array<double, 3> origin{0, 0, 0};
  ScalarType type = ScalarType::u8;
  bool big_endian = false;
  uint64_t header_bytes = 0;  // bytes to skip before the samples
};

LabelVolume read_label_volume(const std::string& path, const RawOptions* raw = nullptr);
FloatVolume read_float_volume(const std::string& path, const RawOptions* raw = nullptr);

// "uint8", "u8", "uchar", "int16", ... (the names --raw-type accepts); throws Error naming `field` otherwise.
ScalarType parse_scalar_type(const std::string& text, const std::string& field);

// Headerless raw samples (what RawOptions reads back).
void write_raw(const std::string& path, const LabelVolume& v, ScalarType type, bool big_endian);

}  // namespace cpmesh::io
