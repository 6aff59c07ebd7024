#include "io/inrimage.h"

#include <map>

#include "io/atomic_file.h"
#include "io/compression.h"
#include "io/error.h"
#include "io/header_text.h"

namespace cpmesh::io {

namespace {
constexpr std::string_view magic = "#INRIMAGE-4#{";
constexpr std::string_view end_mark = "##}\n";
}  // namespace

bool is_inrimage(std::string_view head) { return head.substr(0, magic.size()) == magic; }

VolumeLayout parse_inrimage_header(const std::string& file, std::string_view head) {
  VolumeLayout l;
  l.file = file;
  l.format = "INRIMAGE";
  l.dims_field = "XDIM/YDIM/ZDIM";
  l.type_field = "TYPE/PIXSIZE";
  l.spacing_field = "VX/VY/VZ";
  l.data_field = "data";
  l.data_file = file;
  const size_t end = head.find(end_mark);
  if (end == std::string_view::npos) fail_field(file, "header", "a header closed by '##}'", std::string(head.substr(0, 40)));
  const size_t header_bytes = end + end_mark.size();
  if (header_bytes % 256 != 0)
    fail_field(file, "header", "a header size that is a multiple of 256 bytes", std::to_string(header_bytes) + " bytes");
  l.data_offset = header_bytes;
  std::map<std::string, std::string> fields;
  size_t pos = head.find('\n') + 1;
  while (pos < end) {
    size_t e = head.find('\n', pos);
    if (e == std::string_view::npos || e > end) e = end;
    const std::string line = trim(head.substr(pos, e - pos));
    pos = e + 1;
    if (line.empty() || line[0] == '#') continue;
    const size_t eq = line.find('=');
    if (eq == std::string::npos) fail_field(file, "header line", "'KEY=value'", line);
    fields[trim(line.substr(0, eq))] = trim(line.substr(eq + 1));
  }
  auto get = [&](const std::string& k) -> const std::string* {
    auto it = fields.find(k);
    return it == fields.end() ? nullptr : &it->second;
  };
  const char* dim_keys[3] = {"XDIM", "YDIM", "ZDIM"};
  for (int a = 0; a < 3; ++a) {
    const std::string* s = get(dim_keys[a]);
    if (!s) fail_field(file, dim_keys[a], "the field to be present", "");
    l.dims[a] = parse_int(file, dim_keys[a], *s);
    if (l.dims[a] <= 0) fail_field(file, dim_keys[a], "a positive integer", *s);
  }
  if (const std::string* s = get("VDIM"); s && parse_int(file, "VDIM", *s) != 1)
    fail_field(file, "VDIM", "1 (one label per voxel)", *s);
  const char* sp_keys[3] = {"VX", "VY", "VZ"};
  for (int a = 0; a < 3; ++a)
    if (const std::string* s = get(sp_keys[a])) l.spacing[a] = parse_double(file, sp_keys[a], *s);
  const char* origin_keys[3] = {"TX", "TY", "TZ"};
  for (int a = 0; a < 3; ++a)
    if (const std::string* s = get(origin_keys[a])) l.origin[a] = parse_double(file, origin_keys[a], *s);
  const std::string type = get("TYPE") ? to_lower(*get("TYPE")) : "";
  const std::string* pixsize = get("PIXSIZE");
  if (!pixsize) fail_field(file, "PIXSIZE", "the field to be present", "");
  const auto bits_words = split_words(*pixsize);
  const int64_t bits = bits_words.empty() ? 0 : parse_int(file, "PIXSIZE", bits_words[0]);
  if (type == "unsigned fixed" || type == "signed fixed") {
    const bool s = type == "signed fixed";
    if (bits == 8) l.type = s ? ScalarType::i8 : ScalarType::u8;
    else if (bits == 16) l.type = s ? ScalarType::i16 : ScalarType::u16;
    else if (bits == 32) l.type = s ? ScalarType::i32 : ScalarType::u32;
    else fail_field(file, "PIXSIZE", "8, 16 or 32 bits for fixed types", *pixsize);
  } else if (type == "float") {
    if (bits == 32) l.type = ScalarType::f32;
    else if (bits == 64) l.type = ScalarType::f64;
    else fail_field(file, "PIXSIZE", "32 or 64 bits for float", *pixsize);
    l.type_field = "TYPE";
  } else {
    fail_field(file, "TYPE", "unsigned fixed, signed fixed or float", get("TYPE") ? *get("TYPE") : "");
  }
  if (const std::string* cpu = get("CPU")) {
    const std::string c = to_lower(*cpu);
    if (c == "decm" || c == "alpha" || c == "pc") l.big_endian = false;
    else if (c == "sun" || c == "sgi") l.big_endian = true;
    else fail_field(file, "CPU", "decm, alpha, pc (little-endian) or sun, sgi (big-endian)", *cpu);
  }
  return l;
}

void write_inrimage(const std::string& path, const LabelVolume& v, const VolumeWriteOptions& o) {
  const ScalarType t = label_write_type(v, o);
  const bool is_signed = t == ScalarType::i8 || t == ScalarType::i16 || t == ScalarType::i32;
  std::string header = std::string(magic) + "\nXDIM=" + std::to_string(v.dims[0]) +
                       "\nYDIM=" + std::to_string(v.dims[1]) + "\nZDIM=" + std::to_string(v.dims[2]) +
                       "\nVDIM=1\nTYPE=" + (is_integer(t) ? (is_signed ? "signed fixed" : "unsigned fixed") : "float") +
                       "\nPIXSIZE=" + std::to_string(scalar_size(t) * 8) + " bits\nSCALE=2**0\nCPU=" +
                       (o.big_endian ? "sun" : "decm") + "\nVX=" + format_double(v.spacing[0]) +
                       "\nVY=" + format_double(v.spacing[1]) + "\nVZ=" + format_double(v.spacing[2]) +
                       "\nTX=" + format_double(v.origin[0]) + "\nTY=" + format_double(v.origin[1]) +
                       "\nTZ=" + format_double(v.origin[2]) + "\n";
  const size_t total = (header.size() + end_mark.size() + 255) / 256 * 256;
  header.append(total - header.size() - end_mark.size(), '\n');
  header += end_mark;
  std::string file = header + encode_labels(v, t, o.big_endian, path);
  write_atomically(path, [&](std::ostream& out) { out << (o.compress ? gzip_compress(file) : file); });
}

}  // namespace cpmesh::io
