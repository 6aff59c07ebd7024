#pragma once
// The fields' grid of a labeled volume read from a file or made by cpmesh-synth.
#include "fields/grid.h"
#include "io/volume.h"

namespace cpmesh::fields {

inline Grid grid_of(const io::VolumeGeometry& v) {
  return Grid{glm::ivec3(int(v.dims[0]), int(v.dims[1]), int(v.dims[2])),
              glm::dvec3(v.spacing[0], v.spacing[1], v.spacing[2]), glm::dvec3(v.origin[0], v.origin[1], v.origin[2])};
}

}  // namespace cpmesh::fields
