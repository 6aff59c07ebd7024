#include "io/volume_writer_options.h"

#include <algorithm>

#include "io/error.h"

namespace cpmesh::io {

namespace {

double type_max(ScalarType t) {
  switch (t) {
    case ScalarType::u8: return 255;
    case ScalarType::i8: return 127;
    case ScalarType::u16: return 65535;
    case ScalarType::i16: return 32767;
    default: return 4294967295.0;
  }
}

void check_geometry(const VolumeGeometry& g, size_t samples, const std::string& path) {
  if (g.voxel_count() <= 0 || size_t(g.voxel_count()) != samples)
    fail(path, "cannot write: the volume has " + std::to_string(samples) + " samples for dims " +
                   std::to_string(g.dims[0]) + "x" + std::to_string(g.dims[1]) + "x" + std::to_string(g.dims[2]));
}

}  // namespace

ScalarType label_write_type(const LabelVolume& v, const VolumeWriteOptions& o) {
  if (o.type) return *o.type;
  const uint16_t max = v.labels.empty() ? 0 : *std::max_element(v.labels.begin(), v.labels.end());
  return max <= 255 ? ScalarType::u8 : ScalarType::u16;
}

std::string encode_labels(const LabelVolume& v, ScalarType type, bool big_endian, const std::string& path) {
  check_geometry(v, v.labels.size(), path);
  const uint16_t max = v.labels.empty() ? 0 : *std::max_element(v.labels.begin(), v.labels.end());
  if (is_integer(type) && max > type_max(type))
    fail(path, "cannot write label " + std::to_string(max) + " as " + scalar_name(type));
  std::string out;
  out.reserve(v.labels.size() * scalar_size(type));
  for (uint16_t l : v.labels) store_sample(out, l, type, big_endian);
  return out;
}

std::string encode_floats(const FloatVolume& v, ScalarType type, bool big_endian, const std::string& path) {
  check_geometry(v, v.values.size(), path);
  if (is_integer(type)) fail(path, "cannot write a float field as " + scalar_name(type));
  std::string out;
  out.reserve(v.values.size() * scalar_size(type));
  for (float f : v.values) store_sample(out, f, type, big_endian);
  return out;
}

}  // namespace cpmesh::io
