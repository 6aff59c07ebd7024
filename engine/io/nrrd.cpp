#include "io/nrrd.h"

#include <cmath>
#include <filesystem>
#include <map>

#include "io/atomic_file.h"
#include "io/compression.h"
#include "io/error.h"
#include "io/header_text.h"

namespace cpmesh::io {

namespace {

ScalarType nrrd_type(const std::string& file, const std::string& text) {
  static const std::map<std::string, ScalarType> types = {
      {"uchar", ScalarType::u8},          {"unsigned char", ScalarType::u8},   {"uint8", ScalarType::u8},
      {"uint8_t", ScalarType::u8},        {"signed char", ScalarType::i8},     {"int8", ScalarType::i8},
      {"int8_t", ScalarType::i8},         {"short", ScalarType::i16},          {"short int", ScalarType::i16},
      {"signed short", ScalarType::i16},  {"signed short int", ScalarType::i16}, {"int16", ScalarType::i16},
      {"int16_t", ScalarType::i16},       {"ushort", ScalarType::u16},         {"unsigned short", ScalarType::u16},
      {"unsigned short int", ScalarType::u16}, {"uint16", ScalarType::u16},    {"uint16_t", ScalarType::u16},
      {"int", ScalarType::i32},           {"signed int", ScalarType::i32},     {"int32", ScalarType::i32},
      {"int32_t", ScalarType::i32},       {"uint", ScalarType::u32},           {"unsigned int", ScalarType::u32},
      {"uint32", ScalarType::u32},        {"uint32_t", ScalarType::u32},       {"float", ScalarType::f32},
      {"double", ScalarType::f64}};
  const auto it = types.find(text);
  if (it == types.end())
    fail_field(file, "type", "one of uchar, signed char, ushort, short, uint, int (or float, double for fields)", text);
  return it->second;
}

// "(1,0,0) (0,1,0) (0,0,1)" → vectors; "none" entries are refused (every axis must be spatial).
std::vector<std::array<double, 3>> parse_vectors(const std::string& file, const std::string& field,
                                                 const std::string& text, size_t n) {
  std::vector<std::array<double, 3>> out;
  size_t pos = 0;
  const std::string expected = std::to_string(n) + " vectors like (x,y,z)";
  while (true) {
    const size_t open = text.find('(', pos);
    if (open == std::string::npos) break;
    const size_t close = text.find(')', open);
    if (close == std::string::npos) fail_field(file, field, expected, text);
    const auto v = parse_doubles(file, field, text.substr(open + 1, close - open - 1), 3, expected);
    out.push_back({v[0], v[1], v[2]});
    pos = close + 1;
  }
  if (out.size() != n) fail_field(file, field, expected, text);
  return out;
}

std::string vector_text(double x, double y, double z) { return format_vector(x, y, z); }

void write_nrrd_bytes(const std::string& path, const VolumeGeometry& g, ScalarType type, bool big_endian, bool gzip,
                      const std::string& samples) {
  static const std::map<ScalarType, std::string> names = {
      {ScalarType::u8, "uint8"},   {ScalarType::i8, "int8"},   {ScalarType::u16, "uint16"}, {ScalarType::i16, "int16"},
      {ScalarType::u32, "uint32"}, {ScalarType::i32, "int32"}, {ScalarType::f32, "float"},  {ScalarType::f64, "double"}};
  const std::string data = gzip ? gzip_compress(samples) : samples;
  const bool detached = ends_with(to_lower(path), ".nhdr");
  std::string header = "NRRD0004\n# written by cpmesh\ntype: " + names.at(type) +
                       "\ndimension: 3\nspace dimension: 3\nsizes: " + std::to_string(g.dims[0]) + " " +
                       std::to_string(g.dims[1]) + " " + std::to_string(g.dims[2]) +
                       "\nspace directions: " + vector_text(g.spacing[0], 0, 0) + " " +
                       vector_text(0, g.spacing[1], 0) + " " + vector_text(0, 0, g.spacing[2]) +
                       "\nkinds: domain domain domain\nendian: " + (big_endian ? "big" : "little") +
                       "\nencoding: " + (gzip ? "gzip" : "raw") +
                       "\nspace origin: " + vector_text(g.origin[0], g.origin[1], g.origin[2]) + "\n";
  if (detached) {
    const std::filesystem::path p(path);
    const std::string data_name = p.stem().string() + (gzip ? ".raw.gz" : ".raw");
    write_atomically((p.parent_path() / data_name).string(), [&](std::ostream& out) { out << data; });
    header += "data file: " + data_name + "\n";
    write_atomically(path, [&](std::ostream& out) { out << header; });
  } else {
    write_atomically(path, [&](std::ostream& out) { out << header << '\n' << data; });
  }
}

}  // namespace

bool is_nrrd(std::string_view head) { return head.substr(0, 7) == "NRRD000"; }

VolumeLayout parse_nrrd_header(const std::string& file, std::string_view head) {
  VolumeLayout l;
  l.file = file;
  l.format = "NRRD";
  l.dims_field = "sizes";
  l.type_field = "type";
  l.data_field = "data";
  l.data_file = file;
  std::map<std::string, std::string> fields;
  size_t pos = head.find('\n');
  if (pos == std::string_view::npos) fail(file, "NRRD header: expected a line break after the magic 'NRRD000x'");
  ++pos;
  bool blank_line_seen = false;
  while (pos < head.size()) {
    size_t end = head.find('\n', pos);
    if (end == std::string_view::npos) {
      // An attached header must end with a blank line inside the bytes we sniffed; a detached one may end at EOF.
      end = head.size();
    }
    std::string line(head.substr(pos, end - pos));
    pos = end + 1;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) {
      blank_line_seen = true;
      break;
    }
    if (line[0] == '#') continue;
    if (line.find(":=") != std::string::npos) continue;  // key/value pairs: free-form metadata
    const size_t colon = line.find(": ");
    if (colon == std::string::npos) fail_field(file, "header line", "'field: value'", line);
    fields[line.substr(0, colon)] = trim(line.substr(colon + 2));
  }
  l.data_offset = blank_line_seen ? pos : head.size();
  auto get = [&](const std::string& a, const std::string& b = "") -> const std::string* {
    if (auto it = fields.find(a); it != fields.end()) return &it->second;
    if (auto it = fields.find(b); !b.empty() && it != fields.end()) return &it->second;
    return nullptr;
  };
  auto required = [&](const std::string& name) -> const std::string& {
    const std::string* v = get(name);
    if (!v) fail_field(file, name, "the field to be present", "");
    return *v;
  };

  const int64_t dim = parse_int(file, "dimension", required("dimension"));
  if (dim != 2 && dim != 3) fail_field(file, "dimension", "2 or 3 (one scalar label per voxel)", required("dimension"));
  const auto sizes = parse_ints(file, "sizes", required("sizes"), size_t(dim),
                                std::to_string(dim) + " positive integers");
  for (int a = 0; a < dim; ++a) {
    if (sizes[a] <= 0) fail_field(file, "sizes", std::to_string(dim) + " positive integers", required("sizes"));
    l.dims[a] = sizes[a];
  }
  l.type = nrrd_type(file, required("type"));

  const std::string encoding = required("encoding");
  if (encoding == "gzip" || encoding == "gz")
    l.compression = DataCompression::zlib_or_gzip;
  else if (encoding != "raw")
    fail_field(file, "encoding", "raw or gzip", encoding);

  if (const std::string* e = get("endian")) {
    if (*e != "little" && *e != "big") fail_field(file, "endian", "little or big", *e);
    l.big_endian = *e == "big";
  } else if (scalar_size(l.type) > 1) {
    fail_field(file, "endian", "the field to be present for multi-byte types", "");
  }

  if (const std::string* s = get("spacings")) {
    const auto sp = parse_doubles(file, "spacings", *s, size_t(dim), std::to_string(dim) + " positive numbers");
    for (int a = 0; a < dim; ++a) l.spacing[a] = sp[a];
    l.spacing_field = "spacings";
  }
  if (const std::string* s = get("space directions")) {
    const auto dirs = parse_vectors(file, "space directions", *s, size_t(dim));
    for (int a = 0; a < dim; ++a) {
      const auto& d = dirs[a];
      l.spacing[a] = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      for (int c = 0; c < 3; ++c) l.directions[a][c] = l.spacing[a] > 0 ? d[c] / l.spacing[a] : 0;
    }
    l.spacing_field = "space directions";
    l.directions_field = "space directions";
  }
  if (const std::string* s = get("space origin")) {
    const auto o = parse_vectors(file, "space origin", *s, 1)[0];
    l.origin = o;
  }
  if (const std::string* s = get("line skip", "lineskip"); s && parse_int(file, "line skip", *s) != 0)
    fail_field(file, "line skip", "0", *s);

  if (const std::string* d = get("data file", "datafile")) {
    if (d->find(' ') != std::string::npos || d->rfind("LIST", 0) == 0)
      fail_field(file, "data file", "a single data file name (lists and patterns are not supported)", *d);
    l.data_file = sibling_path(file, *d);
    l.data_field = "data file";
    l.data_offset = 0;
  } else if (!blank_line_seen) {
    fail(file, "NRRD header: expected a blank line before the attached data, or a 'data file' field");
  }
  if (const std::string* s = get("byte skip", "byteskip")) {
    const int64_t skip = parse_int(file, "byte skip", *s);
    if (skip == -1 && l.compression == DataCompression::none)
      l.data_at_end = true;
    else if (skip < 0 || l.compression != DataCompression::none)
      fail_field(file, "byte skip", "-1 or a byte count, with raw encoding", *s);
    else
      l.data_offset += uint64_t(skip);
  }
  return l;
}

void write_nrrd(const std::string& path, const LabelVolume& v, const VolumeWriteOptions& o) {
  const ScalarType t = label_write_type(v, o);
  write_nrrd_bytes(path, v, t, o.big_endian, o.compress, encode_labels(v, t, o.big_endian, path));
}

void write_nrrd(const std::string& path, const LabelVolume& v, bool gzip) {
  VolumeWriteOptions o;
  o.compress = gzip;
  write_nrrd(path, v, o);
}

void write_nrrd(const std::string& path, const FloatVolume& v, bool gzip) {
  write_nrrd_bytes(path, v, ScalarType::f32, false, gzip, encode_floats(v, ScalarType::f32, false, path));
}

}  // namespace cpmesh::io
