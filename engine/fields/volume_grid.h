#pragma once
// The fields' grid of a labeled volume read from a file or made by cpmesh-synth, and what lies outside it.
#include <cmath>

#include "fields/grid.h"
#include "fields/fields_stage.h"
#include "io/volume.h"

namespace cpmesh::fields {

inline Grid grid_of(const io::VolumeGeometry& v) {
  return Grid{glm::ivec3(int(v.dims[0]), int(v.dims[1]), int(v.dims[2])),
              glm::dvec3(v.spacing[0], v.spacing[1], v.spacing[2]), glm::dvec3(v.origin[0], v.origin[1], v.origin[2])};
}

// Outside the volume counts as the background, label 0, as in CGAL's labeled image domain: a material that touches a
// face of the volume is closed there, so every interface is a closed or curve-bounded surface and every material can
// be tet-meshed (a neck cut by the scan's last slice gets a cap). Returns the volume padded by `width` voxels of the
// smallest spacing (rounded up per axis) of label 0 on every side, origin moved so physical positions stay; or the
// volume unchanged when only 0 lies on its faces.
io::LabelVolume close_at_faces(io::LabelVolume volume, double width);  // by value: a closed volume is moved through
// The padding that keeps a cap's indicator band and smoothing inside the padded grid, in voxels, for the fields
// build_fields makes of `v` with these options.
inline double face_padding(const FieldsOptions& options, const io::VolumeGeometry& v) {
  const IndicatorOptions o = resolve_fields_options(options, grid_of(v).min_spacing()).indicator;
  return std::ceil(o.band + 3 * o.smoothing_sigma) + 1;
}

}  // namespace cpmesh::fields
