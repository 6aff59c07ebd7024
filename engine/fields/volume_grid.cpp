#include "fields/volume_grid.h"

#include <algorithm>

namespace cpmesh::fields {

io::LabelVolume close_at_faces(io::LabelVolume volume, double width) {
  const auto& d = volume.dims;
  bool open = false;
  for (int64_t k = 0; k < d[2] && !open; ++k)
    for (int64_t j = 0; j < d[1] && !open; ++j) {
      const bool face = k == 0 || k == d[2] - 1 || j == 0 || j == d[1] - 1;
      for (int64_t i = 0; i < d[0]; i += face ? 1 : std::max<int64_t>(1, d[0] - 1))
        if (volume.labels[volume.index(i, j, k)] != 0) {
          open = true;
          break;
        }
    }
  if (!open) return volume;
  const double h = std::min({volume.spacing[0], volume.spacing[1], volume.spacing[2]});
  std::array<int64_t, 3> pad{};
  io::LabelVolume out;
  static_cast<io::VolumeGeometry&>(out) = volume;
  out.file_type = volume.file_type;
  out.format = volume.format;
  out.source = volume.source;
  for (int a = 0; a < 3; ++a) {
    pad[a] = std::max<int64_t>(1, int64_t(std::ceil(width * h / volume.spacing[a] - 1e-9)));
    out.dims[a] = d[a] + 2 * pad[a];
    out.origin[a] = volume.origin[a] - double(pad[a]) * volume.spacing[a];
  }
  out.labels.assign(size_t(out.voxel_count()), 0);
  for (int64_t k = 0; k < d[2]; ++k)
    for (int64_t j = 0; j < d[1]; ++j)
      std::copy_n(volume.labels.begin() + ptrdiff_t(volume.index(0, j, k)), d[0],
                  out.labels.begin() + ptrdiff_t(out.index(pad[0], j + pad[1], k + pad[2])));
  return out;
}

}  // namespace cpmesh::fields
