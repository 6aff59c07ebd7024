#include "fields/device_fields.h"

#include "fields/volume_grid.h"

namespace cpmesh::fields {

DeviceFields build_device_fields(const gpu::Context& ctx, const io::LabelVolume& volume, FieldsOptions options,
                                 uint64_t max_chunk_bytes) {
  options.embedding.check_blocks = [&ctx, max_chunk_bytes](size_t blocks, int sub) {
    try {
      GpuEmbedding::check_fits(ctx, blocks, sub, max_chunk_bytes);
    } catch (const gpu::Error& e) {
      throw EmbeddingTooLarge(e.what(), sub);
    }
  };
  const bool chosen_sub = options.embedding.sub == 0;
  DeviceFields out;
  for (;;) {
    out.volume = close_at_faces(volume, face_padding(options, volume));
    try {
      out.fields = build_fields(grid_of(out.volume), out.volume.labels.data(), options);
      return out;
    } catch (const EmbeddingTooLarge& e) {
      if (!chosen_sub || e.sub == 1) throw EmbeddingTooLarge(volume.source + ": " + e.what(), e.sub);
      out.one_subcell_because = e.what();
      options.embedding.sub = 1;  // build_fields deepens the indicator band for it where the band was left to it
    }
  }
}

}  // namespace cpmesh::fields
