#include "io/metaimage.h"

#include <filesystem>
#include <map>

#include "io/atomic_file.h"
#include "io/compression.h"
#include "io/error.h"
#include "io/header_text.h"

namespace cpmesh::io {

namespace {

const std::map<std::string, ScalarType>& element_types() {
  static const std::map<std::string, ScalarType> types = {
      {"MET_UCHAR", ScalarType::u8},  {"MET_CHAR", ScalarType::i8},  {"MET_USHORT", ScalarType::u16},
      {"MET_SHORT", ScalarType::i16}, {"MET_UINT", ScalarType::u32}, {"MET_INT", ScalarType::i32},
      {"MET_FLOAT", ScalarType::f32}, {"MET_DOUBLE", ScalarType::f64}};
  return types;
}

bool parse_bool(const std::string& file, const std::string& field, const std::string& text) {
  const std::string t = to_lower(text);
  if (t == "true" || t == "1") return true;
  if (t == "false" || t == "0") return false;
  fail_field(file, field, "True or False", text);
}

}  // namespace

bool is_metaimage(std::string_view head) {
  // Keys may come in any order; one of these opens every MetaImage header in practice.
  for (std::string_view key : {"ObjectType", "NDims"}) {
    if (head.substr(0, key.size()) == key) {
      const auto rest = head.substr(key.size(), 8);
      return rest.find('=') != std::string_view::npos;
    }
  }
  return false;
}

VolumeLayout parse_metaimage_header(const std::string& file, std::string_view head) {
  VolumeLayout l;
  l.file = file;
  l.format = "MetaImage";
  l.dims_field = "DimSize";
  l.type_field = "ElementType";
  l.spacing_field = "ElementSpacing";
  l.directions_field = "TransformMatrix";
  l.data_field = "ElementDataFile";
  std::map<std::string, std::string> fields;
  size_t pos = 0;
  bool found_data_line = false;
  while (pos < head.size() && !found_data_line) {
    size_t end = head.find('\n', pos);
    if (end == std::string_view::npos) end = head.size();
    const std::string line = trim(head.substr(pos, end - pos));
    pos = end + 1;
    if (line.empty()) continue;
    const size_t eq = line.find('=');
    if (eq == std::string::npos) fail_field(file, "header line", "'Key = Value'", line);
    const std::string key = trim(line.substr(0, eq));
    fields[key] = trim(line.substr(eq + 1));
    found_data_line = key == "ElementDataFile";  // always the last key: the data follows its line
  }
  if (!found_data_line) fail_field(file, "ElementDataFile", "the field to be present (as the header's last line)", "");
  auto get = [&](const std::string& k) -> const std::string* {
    auto it = fields.find(k);
    return it == fields.end() ? nullptr : &it->second;
  };
  auto required = [&](const std::string& k) -> const std::string& {
    const std::string* v = get(k);
    if (!v) fail_field(file, k, "the field to be present", "");
    return *v;
  };
  if (const std::string* t = get("ObjectType"); t && *t != "Image") fail_field(file, "ObjectType", "Image", *t);
  const int64_t nd = parse_int(file, "NDims", required("NDims"));
  if (nd != 2 && nd != 3) fail_field(file, "NDims", "2 or 3", required("NDims"));
  const size_t n = size_t(nd);
  const auto dims = parse_ints(file, "DimSize", required("DimSize"), n, std::to_string(n) + " positive integers");
  for (size_t a = 0; a < n; ++a) {
    if (dims[a] <= 0) fail_field(file, "DimSize", std::to_string(n) + " positive integers", required("DimSize"));
    l.dims[a] = dims[a];
  }
  const std::string& type = required("ElementType");
  const auto it = element_types().find(type);
  if (it == element_types().end())
    fail_field(file, "ElementType", "one of MET_UCHAR, MET_CHAR, MET_USHORT, MET_SHORT, MET_UINT, MET_INT", type);
  l.type = it->second;
  if (const std::string* c = get("ElementNumberOfChannels"); c && parse_int(file, "ElementNumberOfChannels", *c) != 1)
    fail_field(file, "ElementNumberOfChannels", "1 (one label per voxel)", *c);
  for (const char* key : {"ElementSpacing", "ElementSize"}) {
    if (const std::string* s = get(key)) {
      const auto sp = parse_doubles(file, key, *s, n, std::to_string(n) + " positive numbers");
      for (size_t a = 0; a < n; ++a) l.spacing[a] = sp[a];
      l.spacing_field = key;
      break;
    }
  }
  for (const char* key : {"Offset", "Origin", "Position"}) {
    if (const std::string* s = get(key)) {
      const auto o = parse_doubles(file, key, *s, n, std::to_string(n) + " numbers");
      for (size_t a = 0; a < n; ++a) l.origin[a] = o[a];
      break;
    }
  }
  for (const char* key : {"TransformMatrix", "Rotation", "Orientation"}) {
    if (const std::string* s = get(key)) {
      // Row a of the matrix is the direction of file axis a (ITK's MetaImageIO convention).
      const auto m = parse_doubles(file, key, *s, n * n, std::to_string(n * n) + " numbers");
      for (size_t a = 0; a < n; ++a)
        for (size_t c = 0; c < n; ++c) l.directions[a][c] = m[a * n + c];
      l.directions_field = key;
      break;
    }
  }
  for (const char* key : {"BinaryDataByteOrderMSB", "ElementByteOrderMSB"})
    if (const std::string* s = get(key)) l.big_endian = parse_bool(file, key, *s);
  if (const std::string* s = get("CompressedData"); s && parse_bool(file, "CompressedData", *s))
    l.compression = DataCompression::zlib_or_gzip;
  if (const std::string* s = get("BinaryData"); s && !parse_bool(file, "BinaryData", *s))
    fail_field(file, "BinaryData", "True (text samples are not supported)", *s);
  const std::string& data = required("ElementDataFile");
  if (data == "LOCAL") {
    l.data_file = file;
    l.data_offset = pos;
  } else {
    if (data.rfind("LIST", 0) == 0 || data.find('%') != std::string::npos)
      fail_field(file, "ElementDataFile", "LOCAL or one file name (lists and patterns are not supported)", data);
    l.data_file = sibling_path(file, data);
    l.data_offset = 0;
  }
  if (const std::string* s = get("HeaderSize")) {
    const int64_t skip = parse_int(file, "HeaderSize", *s);
    if (skip == -1 && l.compression == DataCompression::none)
      l.data_at_end = true;
    else if (skip < 0)
      fail_field(file, "HeaderSize", "-1 or a byte count", *s);
    else
      l.data_offset += uint64_t(skip);
  }
  return l;
}

void write_metaimage(const std::string& path, const LabelVolume& v, const VolumeWriteOptions& o) {
  static const std::map<ScalarType, std::string> names = {
      {ScalarType::u8, "MET_UCHAR"}, {ScalarType::i8, "MET_CHAR"}, {ScalarType::u16, "MET_USHORT"},
      {ScalarType::i16, "MET_SHORT"}, {ScalarType::u32, "MET_UINT"}, {ScalarType::i32, "MET_INT"},
      {ScalarType::f32, "MET_FLOAT"}, {ScalarType::f64, "MET_DOUBLE"}};
  const ScalarType t = label_write_type(v, o);
  const std::string samples = encode_labels(v, t, o.big_endian, path);
  const std::string data = o.compress ? zlib_compress(samples) : samples;
  auto triple = [](const auto& a) { return format_double(double(a[0])) + " " + format_double(double(a[1])) + " " +
                                           format_double(double(a[2])); };
  std::string header = "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = " +
                       std::string(o.big_endian ? "True" : "False") +
                       "\nCompressedData = " + (o.compress ? "True" : "False") +
                       (o.compress ? "\nCompressedDataSize = " + std::to_string(data.size()) : "") +
                       "\nTransformMatrix = 1 0 0 0 1 0 0 0 1\nOffset = " + triple(v.origin) +
                       "\nElementSpacing = " + triple(v.spacing) + "\nDimSize = " + triple(v.dims) +
                       "\nElementType = " + names.at(t) + "\n";
  if (ends_with(to_lower(path), ".mhd")) {
    const std::filesystem::path p(path);
    const std::string data_name = p.stem().string() + (o.compress ? ".zraw" : ".raw");
    write_atomically((p.parent_path() / data_name).string(), [&](std::ostream& out) { out << data; });
    write_atomically(path, [&](std::ostream& out) { out << header << "ElementDataFile = " << data_name << '\n'; });
  } else {
    write_atomically(path, [&](std::ostream& out) { out << header << "ElementDataFile = LOCAL\n" << data; });
  }
}

}  // namespace cpmesh::io
