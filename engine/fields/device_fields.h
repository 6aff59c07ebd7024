#pragma once
// The fields stage on a device (docs/design.md, "Device limits, found early"): the volume closed at its faces and
// its fields, the embedding checked against the device's bindings (GpuEmbedding::check_fits) as soon as its block
// count is known. Where the embedding at two subcells (the default under a size floor below a voxel) would not fit,
// it gets one: an eighth of the fine points, with the lookup error closest_point_embedding.h measures at S = 1, and
// the deeper indicator band that needs (the padding and the fields are made again). Where one does not fit either,
// or the options fixed the subcells, it throws EmbeddingTooLarge, naming the volume.
#include <string>

#include "fields/cp_lookup_gpu.h"
#include "fields/fields_stage.h"
#include "io/volume.h"

namespace cpmesh::fields {

struct DeviceFields {
  io::LabelVolume volume;           // closed at its faces (close_at_faces)
  FieldsResult fields;
  std::string one_subcell_because;  // where two subcells would not fit: the device's refusal of them; else empty
};

// max_chunk_bytes: as GpuEmbedding's (0: the device's limits; tests lower it).
DeviceFields build_device_fields(const gpu::Context& ctx, const io::LabelVolume& volume, FieldsOptions options,
                                 uint64_t max_chunk_bytes = 0);

}  // namespace cpmesh::fields
