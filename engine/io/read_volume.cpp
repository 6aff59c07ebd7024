#include "io/read_volume.h"

#include <map>

#include "io/atomic_file.h"
#include "io/compression.h"
#include "io/error.h"
#include "io/header_text.h"
#include "io/inrimage.h"
#include "io/metaimage.h"
#include "io/nifti.h"
#include "io/nrrd.h"
#include "io/volume_layout.h"
#include "io/volume_writer_options.h"

namespace cpmesh::io {

namespace {

// Every header we read fits in this many bytes; reading only them keeps sniffing cheap for huge files.
constexpr uint64_t sniff_bytes = 1 << 16;

struct Located {
  VolumeLayout layout;
  std::string whole_file_gzip;  // the compressed file when the whole file was gzip-compressed
  bool gzipped = false;
};

Located locate(const std::string& path, const RawOptions* raw) {
  check_regular_file(path);
  Located r;
  std::string head = read_file_range(path, 0, sniff_bytes);
  if (has_gzip_magic(head)) {
    r.gzipped = true;
    r.whole_file_gzip = read_file_range(path, 0, UINT64_MAX);
    bool complete = false;
    head = inflate_stream(r.whole_file_gzip, sniff_bytes, path, "gzip", &complete);
  }
  if (is_nrrd(head)) {
    r.layout = parse_nrrd_header(path, head);
  } else if (is_nifti(head)) {
    r.layout = parse_nifti_header(path, head);
  } else if (is_inrimage(head)) {
    r.layout = parse_inrimage_header(path, head);
  } else if (is_metaimage(head)) {
    r.layout = parse_metaimage_header(path, head);
  } else if (raw) {
    VolumeLayout& l = r.layout;
    l.file = path;
    l.format = "raw";
    l.dims = raw->dims;
    l.dims_field = "--raw-dims";
    l.spacing = raw->spacing;
    l.spacing_field = "--raw-spacing";
    l.origin = raw->origin;
    l.type = raw->type;
    l.type_field = "--raw-type";
    l.big_endian = raw->big_endian;
    l.data_file = path;
    l.data_field = "data";
    l.data_offset = raw->header_bytes;
  } else {
    fail(path, "unrecognised volume format (expected a NRRD, NIfTI-1, MetaImage or INRIMAGE header, or gzip of one; "
               "a headerless raw file needs --raw-dims, --raw-type and --raw-spacing)");
  }
  if (r.gzipped && r.layout.data_file != path)
    fail(path, "a gzip-compressed header with a separate data file is not supported; compress the data instead");
  return r;
}

}  // namespace

LabelVolume read_label_volume(const std::string& path, const RawOptions* raw) {
  const Located r = locate(path, raw);
  return load_label_layout(r.layout, r.gzipped ? &r.whole_file_gzip : nullptr);
}

FloatVolume read_float_volume(const std::string& path, const RawOptions* raw) {
  const Located r = locate(path, raw);
  return load_float_layout(r.layout, r.gzipped ? &r.whole_file_gzip : nullptr);
}

ScalarType parse_scalar_type(const std::string& text, const std::string& field) {
  static const std::map<std::string, ScalarType> names = {
      {"u8", ScalarType::u8},     {"uint8", ScalarType::u8},   {"uchar", ScalarType::u8},
      {"i8", ScalarType::i8},     {"int8", ScalarType::i8},    {"char", ScalarType::i8},
      {"u16", ScalarType::u16},   {"uint16", ScalarType::u16}, {"ushort", ScalarType::u16},
      {"i16", ScalarType::i16},   {"int16", ScalarType::i16},  {"short", ScalarType::i16},
      {"u32", ScalarType::u32},   {"uint32", ScalarType::u32}, {"uint", ScalarType::u32},
      {"i32", ScalarType::i32},   {"int32", ScalarType::i32},  {"int", ScalarType::i32},
      {"f32", ScalarType::f32},   {"float32", ScalarType::f32}, {"float", ScalarType::f32},
      {"f64", ScalarType::f64},   {"float64", ScalarType::f64}, {"double", ScalarType::f64}};
  const auto it = names.find(to_lower(text));
  if (it == names.end()) throw Error("field '" + field + "': expected u8, i8, u16, i16, u32 or i32, got '" + text + "'");
  return it->second;
}

void write_raw(const std::string& path, const LabelVolume& v, ScalarType type, bool big_endian) {
  const std::string bytes = encode_labels(v, type, big_endian, path);
  write_atomically(path, [&](std::ostream& out) { out << bytes; });
}

}  // namespace cpmesh::io
