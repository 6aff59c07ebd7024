#include "io/nifti.h"

#include <cmath>
#include <cstring>
#include <map>

#include "io/atomic_file.h"
#include "io/compression.h"
#include "io/error.h"
#include "io/header_text.h"

namespace cpmesh::io {

namespace {

constexpr size_t header_size = 348;

// Reads fields of the 348-byte header in the file's byte order.
struct HeaderReader {
  std::string_view bytes;
  bool big_endian;
  int64_t i16(size_t off) const { return int64_t(load_sample(data() + off, 0, ScalarType::i16, big_endian)); }
  float f32_at(size_t off) const { return float(load_sample(data() + off, 0, ScalarType::f32, big_endian)); }
  const unsigned char* data() const { return reinterpret_cast<const unsigned char*>(bytes.data()); }
};

int32_t sizeof_hdr(std::string_view head, bool big_endian) {
  return int32_t(load_sample(reinterpret_cast<const unsigned char*>(head.data()), 0, ScalarType::i32, big_endian));
}

}  // namespace

bool is_nifti(std::string_view head) {
  return head.size() >= header_size && (sizeof_hdr(head, false) == 348 || sizeof_hdr(head, true) == 348) &&
         (head.substr(344, 4) == std::string_view("n+1\0", 4) || head.substr(344, 4) == std::string_view("ni1\0", 4));
}

VolumeLayout parse_nifti_header(const std::string& file, std::string_view head) {
  if (head.size() < header_size)
    fail(file, "NIfTI header: expected 348 bytes, got " + std::to_string(head.size()) + " (truncated)");
  VolumeLayout l;
  l.file = file;
  l.format = "NIfTI-1";
  l.dims_field = "dim";
  l.type_field = "datatype";
  l.spacing_field = "pixdim";
  l.data_field = "vox_offset";
  l.data_file = file;
  const HeaderReader h{head, sizeof_hdr(head, false) != 348};
  l.big_endian = h.big_endian;
  if (head.substr(344, 4) != std::string_view("n+1\0", 4))
    fail_field(file, "magic", "'n+1' (single-file NIfTI; .hdr/.img pairs are not supported)", std::string(head.substr(344, 3)));

  const int64_t ndim = h.i16(40);
  std::array<int64_t, 8> dim{};
  std::string dim_text;
  for (int a = 0; a < 8; ++a) {
    dim[a] = h.i16(40 + 2 * a);
    dim_text += a ? " " : "";
    dim_text += std::to_string(dim[a]);
  }
  if (ndim < 2 || ndim > 7) fail_field(file, "dim", "dim[0] between 2 and 7", dim_text);
  for (int a = 4; a <= ndim; ++a)
    if (dim[a] != 1) fail_field(file, "dim", "a 3-D volume (dim[4..] = 1: one label per voxel)", dim_text);
  for (int a = 1; a <= std::min<int64_t>(ndim, 3); ++a) {
    if (dim[a] <= 0) fail_field(file, "dim", "positive sizes", dim_text);
    l.dims[a - 1] = dim[a];
  }

  const int64_t datatype = h.i16(70);
  switch (datatype) {
    case 2: l.type = ScalarType::u8; break;
    case 4: l.type = ScalarType::i16; break;
    case 8: l.type = ScalarType::i32; break;
    case 16: l.type = ScalarType::f32; break;
    case 64: l.type = ScalarType::f64; break;
    case 256: l.type = ScalarType::i8; break;
    case 512: l.type = ScalarType::u16; break;
    case 768: l.type = ScalarType::u32; break;
    default:
      fail_field(file, "datatype", "2 (uint8), 4 (int16), 8 (int32), 256 (int8), 512 (uint16) or 768 (uint32)",
                 std::to_string(datatype));
  }
  const float slope = h.f32_at(112), inter = h.f32_at(116);
  if (!(slope == 0 || slope == 1) || inter != 0)
    fail_field(file, "scl_slope", "no intensity scaling for labels (scl_slope 0 or 1, scl_inter 0)",
               format_double(slope) + " " + format_double(inter));
  const double vox_offset = h.f32_at(108);
  if (!(vox_offset >= 348) || vox_offset != std::floor(vox_offset) || vox_offset > 1e9)
    fail_field(file, "vox_offset", "a whole number of bytes >= 348", format_double(vox_offset));
  l.data_offset = uint64_t(vox_offset);

  std::array<double, 4> pixdim{};
  for (int a = 0; a < 4; ++a) pixdim[a] = h.f32_at(76 + 4 * a);
  const int64_t qform = h.i16(252), sform = h.i16(254);
  if (sform > 0) {
    l.directions_field = "srow_x/srow_y/srow_z (sform)";
    l.spacing_field = "srow_x/srow_y/srow_z (sform)";
    for (int r = 0; r < 3; ++r) {
      for (int a = 0; a < 3; ++a) l.directions[a][r] = h.f32_at(280 + 16 * r + 4 * a);
      l.origin[r] = h.f32_at(280 + 16 * r + 12);
    }
    for (int a = 0; a < 3; ++a) {
      auto& d = l.directions[a];
      l.spacing[a] = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      if (l.spacing[a] > 0)
        for (double& c : d) c /= l.spacing[a];
    }
  } else {
    for (int a = 0; a < 3; ++a) l.spacing[a] = pixdim[a + 1];
    if (qform > 0) {
      l.directions_field = "quatern_b/c/d (qform)";
      const double b = h.f32_at(256), c = h.f32_at(260), d = h.f32_at(264);
      const double a = std::sqrt(std::max(0.0, 1.0 - (b * b + c * c + d * d)));
      const double qfac = pixdim[0] < 0 ? -1 : 1;
      const double R[3][3] = {{a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)},
                              {2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b)},
                              {2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - c * c - b * b}};
      for (int ax = 0; ax < 3; ++ax)
        for (int r = 0; r < 3; ++r) l.directions[ax][r] = R[r][ax] * (ax == 2 ? qfac : 1);
      for (int r = 0; r < 3; ++r) l.origin[r] = h.f32_at(268 + 4 * r);
    }
  }
  return l;
}

void write_nifti(const std::string& path, const LabelVolume& v, const VolumeWriteOptions& o) {
  const ScalarType t = label_write_type(v, o);
  for (int64_t d : v.dims)
    if (d > 32767) fail(path, "cannot write NIfTI-1: dims above 32767 do not fit its int16 'dim' field");
  const bool be = o.big_endian;
  // Fixed offsets of the NIfTI-1 header; 352 = header + the 4-byte empty extension block.
  std::string hdr(352, '\0');
  auto put = [&](size_t offset, double x, ScalarType type) {
    std::string bytes;
    store_sample(bytes, x, type, be);
    hdr.replace(offset, bytes.size(), bytes);
  };
  put(0, 348, ScalarType::i32);
  const std::array<double, 8> dim = {3, double(v.dims[0]), double(v.dims[1]), double(v.dims[2]), 1, 1, 1, 1};
  for (size_t a = 0; a < 8; ++a) put(40 + 2 * a, dim[a], ScalarType::i16);
  static const std::map<ScalarType, int> codes = {{ScalarType::u8, 2},    {ScalarType::i16, 4},  {ScalarType::i32, 8},
                                                  {ScalarType::f32, 16},  {ScalarType::f64, 64}, {ScalarType::i8, 256},
                                                  {ScalarType::u16, 512}, {ScalarType::u32, 768}};
  put(70, codes.at(t), ScalarType::i16);
  put(72, double(scalar_size(t) * 8), ScalarType::i16);
  const std::array<double, 8> pixdim = {1, v.spacing[0], v.spacing[1], v.spacing[2], 1, 1, 1, 1};
  for (size_t a = 0; a < 8; ++a) put(76 + 4 * a, pixdim[a], ScalarType::f32);
  put(108, 352, ScalarType::f32);  // vox_offset
  put(112, 1, ScalarType::f32);    // scl_slope
  put(252, 1, ScalarType::i16);    // qform_code: scanner-anat, identity rotation
  put(254, 1, ScalarType::i16);    // sform_code
  for (size_t r = 0; r < 3; ++r) {
    put(268 + 4 * r, v.origin[r], ScalarType::f32);
    for (size_t c = 0; c < 4; ++c) put(280 + 16 * r + 4 * c, c == 3 ? v.origin[r] : (c == r ? v.spacing[r] : 0.0), ScalarType::f32);
  }
  hdr.replace(344, 4, std::string("n+1\0", 4));
  hdr += encode_labels(v, t, be, path);
  write_atomically(path, [&](std::ostream& out) { out << (o.compress ? gzip_compress(hdr) : hdr); });
}

}  // namespace cpmesh::io
