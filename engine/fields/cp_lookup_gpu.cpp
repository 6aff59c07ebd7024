#include "fields/cp_lookup_gpu.h"

#include <algorithm>

#include "cpmesh/shaders.h"
#include "gpu/describe.h"

namespace cpmesh::fields {

GpuEmbedding::GpuEmbedding(gpu::Context& ctx, const ClosestPointEmbedding& E, uint64_t max_chunk_bytes)
    : keys(ctx, E.keys, "embedding keys"),
      blocks(ctx, E.blocks, "embedding blocks"),
      dims(E.grid.dims),
      sub(E.sub),
      spacing(E.grid.spacing),
      table_mask(uint32_t(E.keys.size() - 1)) {
  const uint64_t block_bytes = uint64_t(E.sub * E.sub * E.sub) * sizeof(glm::vec4);
  const uint64_t limit = max_chunk_bytes ? max_chunk_bytes : ctx.info().max_storage_buffer_range;
  chunk_blocks = uint32_t(std::max<uint64_t>(1, limit / block_bytes));
  const size_t total_blocks = E.block_count();
  if (total_blocks > size_t(chunk_blocks) * kFineChunks)
    throw gpu::Error("the closest point embedding has " + std::to_string(total_blocks) + " blocks (" +
                     gpu::format_bytes(total_blocks * block_bytes) + "); " + ctx.info().name + " binds at most " +
                     std::to_string(kFineChunks) + " x " + gpu::format_bytes(uint64_t(chunk_blocks) * block_bytes) +
                     "; use fewer subcells (--subcells), a coarser volume, or a device with a larger "
                     "maxStorageBufferRange");
  const size_t per_block = size_t(E.sub * E.sub * E.sub);
  for (int c = 0; c < kFineChunks; ++c) {
    const size_t first = std::min(total_blocks, size_t(c) * chunk_blocks);
    const size_t last = std::min(total_blocks, size_t(c + 1) * chunk_blocks);
    fine[size_t(c)] = gpu::Buffer<glm::vec4>(
        ctx, std::span<const glm::vec4>(E.fine.data() + first * per_block, (last - first) * per_block),
        "embedding fine points " + std::to_string(c));
  }
}

CpLookup::CpLookup(gpu::Context& ctx) : kernel_(ctx, shaders::cp_lookup) {}

void CpLookup::record(gpu::Sequence& seq, const GpuEmbedding& e, const gpu::Buffer<glm::vec4>& queries,
                      const gpu::Buffer<glm::vec4>& results, const gpu::Buffer<uint32_t>& valid, uint32_t n) const {
  if (n > queries.size() || n > results.size() || n > valid.size()) throw gpu::Error("cp lookup: n exceeds a buffer");
  struct {
    glm::ivec4 dims_sub;
    glm::vec4 spacing;
    uint32_t n, table_mask, chunk_blocks;
  } push{glm::ivec4(e.dims, e.sub), glm::vec4(e.spacing, 0.0f), n, e.table_mask, e.chunk_blocks};
  static_assert(sizeof(push) == 44);
  seq.dispatch(kernel_, {e.keys, e.blocks, e.fine[0], e.fine[1], e.fine[2], e.fine[3], queries, results, valid}, push, n);
}

}  // namespace cpmesh::fields
