#pragma once
// The closest point embedding on the GPU and the batch lookup kernel (shaders/cp_lookup.comp). The particle system
// binds the same three buffers and includes shaders/shared/cp_lookup.glsl in its advection kernel.
#include "fields/closest_point_embedding.h"
#include "gpu/sequence.h"

namespace cpmesh::fields {

struct GpuEmbedding {
  GpuEmbedding(gpu::Context& ctx, const ClosestPointEmbedding& embedding);
  gpu::Buffer<uint64_t> keys;     // read as uvec2 (low word first)
  gpu::Buffer<uint32_t> blocks;
  gpu::Buffer<glm::vec4> fine;
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
