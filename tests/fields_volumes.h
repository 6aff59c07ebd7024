#pragma once
// Synthetic volumes (io::make_synth_volume, the generator behind cpmesh-synth) as the fields see them, and distances
// to their analytic junctions.
#include <algorithm>
#include <cmath>
#include <vector>

#include "fields/volume_grid.h"
#include "io/synth_volumes.h"

namespace cpmesh::test {

struct FieldsVolume {
  fields::Grid grid;
  std::vector<uint16_t> labels;
  glm::dvec3 centre{0.0};
  io::Junctions junctions;
};

inline FieldsVolume make_volume(io::SynthShape shape, int size, double radius = 0) {
  io::SynthOptions o;
  o.shape = shape;
  o.size = size;
  o.radius = radius;
  auto s = io::make_synth_volume(o);
  return {fields::grid_of(s.volume), std::move(s.volume.labels), glm::dvec3(s.centre[0], s.centre[1], s.centre[2]),
          std::move(s.junctions)};
}

// A labeled volume of the given dims (unit spacing, origin 0) whose voxel (i, j, k) has label_of(i, j, k).
template <class LabelOf>
io::LabelVolume label_volume(int nx, int ny, int nz, LabelOf&& label_of) {
  io::LabelVolume v;
  v.dims = {nx, ny, nz};
  v.labels.resize(size_t(v.voxel_count()));
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) v.labels[size_t(v.index(i, j, k))] = uint16_t(label_of(i, j, k));
  return v;
}

// Distance from p to the analytic triple curve(s) of the given (ascending) labels.
inline double distance_to_curve(const io::Junctions& j, const std::array<uint16_t, 3>& materials, const glm::dvec3& p) {
  return io::distance_to_triple_curve(j, materials, {p.x, p.y, p.z});
}

}  // namespace cpmesh::test
