#include "fields/cp_lookup_gpu.h"

#include "cpmesh/shaders.h"

namespace cpmesh::fields {

GpuEmbedding::GpuEmbedding(gpu::Context& ctx, const ClosestPointEmbedding& E)
    : keys(ctx, E.keys, "embedding keys"),
      blocks(ctx, E.blocks, "embedding blocks"),
      fine(ctx, E.fine, "embedding fine points"),
      dims(E.grid.dims),
      sub(E.sub),
      spacing(E.grid.spacing),
      table_mask(uint32_t(E.keys.size() - 1)) {}

CpLookup::CpLookup(gpu::Context& ctx) : kernel_(ctx, shaders::cp_lookup) {}

void CpLookup::record(gpu::Sequence& seq, const GpuEmbedding& e, const gpu::Buffer<glm::vec4>& queries,
                      const gpu::Buffer<glm::vec4>& results, const gpu::Buffer<uint32_t>& valid, uint32_t n) const {
  if (n > queries.size() || n > results.size() || n > valid.size()) throw gpu::Error("cp lookup: n exceeds a buffer");
  struct {
    glm::ivec4 dims_sub;
    glm::vec4 spacing;
    uint32_t n, table_mask;
  } push{glm::ivec4(e.dims, e.sub), glm::vec4(e.spacing, 0.0f), n, e.table_mask};
  static_assert(sizeof(push) == 40);
  seq.dispatch(kernel_, {e.keys, e.blocks, e.fine, queries, results, valid}, push, n);
}

}  // namespace cpmesh::fields
