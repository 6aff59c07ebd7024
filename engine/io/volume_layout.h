#pragma once
// What a volume header says, in one shape for every format: each format's parser fills a VolumeLayout from its header
// and load_layout (shared) reads, decompresses, checks and decodes the samples and applies the axis directions. Keeping
// the data path shared means every format gets the same size checks and the same error messages.
#include <array>
#include <cstdint>
#include <string>
#include <string_view>

#include "io/volume.h"

namespace cpmesh::io {

enum class DataCompression { none, zlib_or_gzip };

struct VolumeLayout {
  std::string file;   // the header file, for messages
  std::string format; // "NRRD", ...
  std::array<int64_t, 3> dims{1, 1, 1};
  std::string dims_field;  // header field the dims came from, for size-mismatch messages
  std::array<double, 3> spacing{1, 1, 1};
  std::string spacing_field = "spacing";
  std::array<double, 3> origin{0, 0, 0};
  // directions[a] = unit direction of file axis a in world space. Signed permutations are applied; others refused.
  std::array<std::array<double, 3>, 3> directions{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  std::string directions_field;
  ScalarType type = ScalarType::u8;
  std::string type_field;
  bool big_endian = false;
  // Where the samples are: in `data_file` (the header file itself when attached) from byte `data_offset`, or, when
  // the whole file was gzip-compressed (.nii.gz, .inr.gz), at `data_offset` in the inflated file.
  std::string data_file;
  std::string data_field;  // "data file", "ElementDataFile", ... (or "data" when attached)
  uint64_t data_offset = 0;
  bool data_at_end = false;  // NRRD "byte skip: -1": the samples are the file's last bytes
  DataCompression compression = DataCompression::none;

  int64_t voxel_count() const { return dims[0] * dims[1] * dims[2]; }
};

// Upper bound on voxels per volume: far above any segmentation, far below sizes whose products overflow.
constexpr int64_t max_voxel_count = int64_t(1) << 34;

// Checks dims (positive, product without overflow, below max_voxel_count and the machine's memory for `bytes_per_voxel`)
// and throws Error naming `field` otherwise.
void check_dims(const std::string& file, const std::string& field, const std::array<int64_t, 3>& dims,
                size_t bytes_per_voxel);
// Checks spacing values are finite and positive.
void check_spacing(const std::string& file, const std::string& field, const std::array<double, 3>& spacing);

// `whole_file_gzip`: the file's bytes when the whole file is gzip-compressed (.nii.gz, .inr.gz); the layout then
// describes the inflated content.
LabelVolume load_label_layout(const VolumeLayout& layout, const std::string* whole_file_gzip);
FloatVolume load_float_layout(const VolumeLayout& layout, const std::string* whole_file_gzip);

}  // namespace cpmesh::io
