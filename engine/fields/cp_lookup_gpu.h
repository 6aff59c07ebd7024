#pragma once
// The closest point embedding on the GPU and the batch lookup kernel (shaders/cp_lookup.comp). The particle system
// binds the same three buffers and includes shaders/shared/cp_lookup.glsl in its advection kernel.
#include <array>

#include "fields/closest_point_embedding.h"
#include "gpu/sequence.h"

namespace cpmesh::fields {

// The fine points are split over kFineChunks buffers of whole blocks, each within maxStorageBufferRange (128 MiB on
// lavapipe), so an embedding of up to four times that size can be bound.
struct GpuEmbedding {
  static constexpr int kFineChunks = 4;
  // max_chunk_bytes: 0 = the device's maxStorageBufferRange; tests lower it to exercise the split on small data.
  GpuEmbedding(gpu::Context& ctx, const ClosestPointEmbedding& embedding, uint64_t max_chunk_bytes = 0);
  gpu::Buffer<uint64_t> keys;     // read as uvec2 (low word first)
  gpu::Buffer<uint32_t> blocks;
  std::array<gpu::Buffer<glm::vec4>, kFineChunks> fine;
  uint32_t chunk_blocks = 0;      // blocks per fine chunk
  glm::ivec3 dims;
  int sub;
  glm::vec3 spacing;
  uint32_t table_mask;
};

class CpLookup {
 public:
  explicit CpLookup(gpu::Context& ctx);
  // queries: xyz local position, w = the feature id's bits (glm::uintBitsToFloat). results: closest point + sizing.
  void record(gpu::Sequence& seq, const GpuEmbedding& embedding, const gpu::Buffer<glm::vec4>& queries,
              const gpu::Buffer<glm::vec4>& results, const gpu::Buffer<uint32_t>& valid, uint32_t n) const;

 private:
  gpu::Kernel kernel_;
};

}  // namespace cpmesh::fields
