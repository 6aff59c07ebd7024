#include "io/volume_layout.h"

#include <unistd.h>

#include <cmath>

#include "io/compression.h"
#include "io/error.h"
#include "io/header_text.h"

namespace cpmesh::io {

namespace {

std::string dims_text(const std::array<int64_t, 3>& d) {
  return std::to_string(d[0]) + "x" + std::to_string(d[1]) + "x" + std::to_string(d[2]);
}

uint64_t physical_memory_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  return pages > 0 && page > 0 ? uint64_t(pages) * uint64_t(page) : UINT64_MAX;
}

[[noreturn]] void size_mismatch(const VolumeLayout& l, uint64_t expected, uint64_t got, bool truncated) {
  const std::string where = l.data_file == l.file || l.data_file.empty() ? "" : " in '" + l.data_file + "'";
  fail(l.file, "field '" + l.data_field + "': expected " + std::to_string(expected) + " bytes of samples" + where +
                   " (" + dims_text(l.dims) + " voxels of " + scalar_name(l.type) + " from fields '" + l.dims_field +
                   "' and '" + l.type_field + "'), got " + std::to_string(got) +
                   (truncated ? " (truncated data)" : " (more data than the header describes)"));
}

// The sample bytes, exactly as many as the header describes.
std::string sample_bytes(const VolumeLayout& l, const std::string* whole_file_gzip) {
  const uint64_t n = uint64_t(l.voxel_count()) * scalar_size(l.type);
  if (whole_file_gzip) {
    bool complete = false;
    std::string all = inflate_stream(*whole_file_gzip, l.data_offset + n + 1, l.file, "gzip", &complete);
    const uint64_t got = all.size() > l.data_offset ? all.size() - l.data_offset : 0;
    if (got != n) size_mismatch(l, n, got, got < n);
    return all.substr(l.data_offset);
  }
  check_regular_file(l.data_file, "data");
  const uint64_t size = file_size_of(l.data_file);
  if (l.compression == DataCompression::none) {
    const uint64_t offset = l.data_at_end ? (size >= n ? size - n : 0) : l.data_offset;
    const uint64_t got = size > offset ? size - offset : 0;
    if (got != n) size_mismatch(l, n, got, got < n);
    return read_file_range(l.data_file, offset, n);
  }
  // A valid deflate stream of n bytes is at most about 0.1% larger than n (stored blocks): reading more than that
  // cannot help, and a huge file named by a small header must not be read whole into memory.
  const std::string compressed = read_file_range(l.data_file, l.data_offset, n + n / 1000 + (1u << 20));
  bool complete = false;
  std::string out = inflate_stream(compressed, n + 1, l.file, l.data_field, &complete);
  if (out.size() != n) size_mismatch(l, n, out.size(), out.size() < n);
  return out;
}

struct AxisMap {
  std::array<int, 3> world{0, 1, 2};  // file axis a runs along world axis world[a]
  std::array<bool, 3> flip{false, false, false};
  bool identity() const { return world == std::array<int, 3>{0, 1, 2} && !flip[0] && !flip[1] && !flip[2]; }
};

AxisMap axis_map(const VolumeLayout& l) {
  AxisMap m;
  std::array<bool, 3> used{false, false, false};
  for (int a = 0; a < 3; ++a) {
    const auto& d = l.directions[a];
    const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    int w = 0;
    for (int c = 1; c < 3; ++c)
      if (std::abs(d[c]) > std::abs(d[w])) w = c;
    bool aligned = len > 0 && !used[w];
    for (int c = 0; c < 3 && aligned; ++c) aligned = c == w ? std::abs(d[c] / len) > 1 - 1e-6 : std::abs(d[c] / len) < 1e-6;
    if (!aligned) {
      std::string text;
      for (const auto& v : l.directions)
        text += format_vector(v[0], v[1], v[2]) + " ";
      fail_field(l.file, l.directions_field,
                 "axis-aligned directions (axis permutations and flips are applied; an oblique volume must be "
                 "resampled to an axis-aligned grid first)",
                 trim(text));
    }
    used[w] = true;
    m.world[a] = w;
    m.flip[a] = d[w] < 0;
  }
  return m;
}

// Reorders file-ordered samples into world-axis order and sets the geometry accordingly.
template <typename T>
void orient(const VolumeLayout& l, std::vector<T>& samples, VolumeGeometry& g) {
  const AxisMap m = axis_map(l);
  for (int a = 0; a < 3; ++a) {
    const int w = m.world[a];
    g.dims[w] = l.dims[a];
    g.spacing[w] = l.spacing[a];
    g.origin[w] = m.flip[a] ? l.origin[w] - double(l.dims[a] - 1) * l.spacing[a] : l.origin[w];
  }
  if (m.identity()) return;
  std::vector<T> out(samples.size());
  size_t src = 0;
  std::array<int64_t, 3> idx{}, o{};
  for (idx[2] = 0; idx[2] < l.dims[2]; ++idx[2])
    for (idx[1] = 0; idx[1] < l.dims[1]; ++idx[1])
      for (idx[0] = 0; idx[0] < l.dims[0]; ++idx[0], ++src) {
        for (int a = 0; a < 3; ++a) o[m.world[a]] = m.flip[a] ? l.dims[a] - 1 - idx[a] : idx[a];
        out[g.index(o[0], o[1], o[2])] = samples[src];
      }
  samples.swap(out);
}

void check_layout(const VolumeLayout& l, size_t out_bytes_per_voxel) {
  check_dims(l.file, l.dims_field, l.dims, scalar_size(l.type) + out_bytes_per_voxel);
  for (int a = 0; a < 3; ++a)
    if (!std::isfinite(l.origin[a])) fail_field(l.file, "origin", "finite numbers", format_double(l.origin[a]));
}

}  // namespace

void check_dims(const std::string& file, const std::string& field, const std::array<int64_t, 3>& dims,
                size_t bytes_per_voxel) {
  int64_t total = 1;
  for (int64_t d : dims) {
    if (d <= 0) fail_field(file, field, "positive sizes", dims_text(dims));
    if (total > max_voxel_count / d)
      fail_field(file, field, "at most " + std::to_string(max_voxel_count) + " voxels in all", dims_text(dims));
    total *= d;
  }
  const uint64_t need = uint64_t(total) * bytes_per_voxel, have = physical_memory_bytes();
  if (need > have)
    fail_field(file, field,
               "a volume that fits in memory (" + std::to_string(need >> 20) + " MiB needed, the machine has " +
                   std::to_string(have >> 20) + " MiB)",
               dims_text(dims));
}

void check_spacing(const std::string& file, const std::string& field, const std::array<double, 3>& spacing) {
  for (double s : spacing)
    if (!std::isfinite(s) || s <= 0)
      fail_field(file, field, "positive spacings",
                 format_double(spacing[0]) + " " + format_double(spacing[1]) + " " + format_double(spacing[2]));
}

LabelVolume load_label_layout(const VolumeLayout& l, const std::string* whole_file_gzip) {
  if (!is_integer(l.type))
    fail_field(l.file, l.type_field, "an integer sample type (labels must be integers)", scalar_name(l.type));
  check_layout(l, sizeof(uint16_t));
  check_spacing(l.file, l.spacing_field, l.spacing);
  const std::string bytes = sample_bytes(l, whole_file_gzip);
  LabelVolume v;
  v.labels.resize(size_t(l.voxel_count()));
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  for (size_t s = 0; s < v.labels.size(); ++s) {
    const double value = load_sample(p, s, l.type, l.big_endian);
    if (value < 0 || value > 65535) {
      const auto nx = size_t(l.dims[0]), ny = size_t(l.dims[1]);
      fail(l.file, "voxel (" + std::to_string(s % nx) + "," + std::to_string(s / nx % ny) + "," +
                       std::to_string(s / (nx * ny)) + ") of the file: label " + format_double(value) +
                       " is outside 0..65535 (labels are stored as uint16)");
    }
    v.labels[s] = uint16_t(value);
  }
  orient(l, v.labels, v);
  v.file_type = l.type;
  v.format = l.format;
  v.source = l.file;
  return v;
}

FloatVolume load_float_layout(const VolumeLayout& l, const std::string* whole_file_gzip) {
  check_layout(l, sizeof(float));
  check_spacing(l.file, l.spacing_field, l.spacing);
  const std::string bytes = sample_bytes(l, whole_file_gzip);
  FloatVolume v;
  v.values.resize(size_t(l.voxel_count()));
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  for (size_t s = 0; s < v.values.size(); ++s) v.values[s] = float(load_sample(p, s, l.type, l.big_endian));
  orient(l, v.values, v);
  v.source = l.file;
  return v;
}

}  // namespace cpmesh::io
