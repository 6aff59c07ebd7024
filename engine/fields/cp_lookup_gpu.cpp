#include "fields/cp_lookup_gpu.h"

#include <algorithm>

#include <tbb/parallel_sort.h>

#include "cpmesh/shaders.h"
#include "gpu/describe.h"

namespace cpmesh::fields {

namespace {

uint64_t tile_key(const glm::ivec3& tile, const glm::ivec3& tile_dims, uint32_t feature) {
  const size_t index = (size_t(tile.z) * size_t(tile_dims.y) + size_t(tile.y)) * size_t(tile_dims.x) + size_t(tile.x);
  return (uint64_t(index) << 16) | feature;
}

uint32_t cell_in_tile(const glm::ivec3& cell) {
  const glm::ivec3 l = cell & ((1 << EmbeddingTiles::kShift) - 1);
  return uint32_t((l.z << (2 * EmbeddingTiles::kShift)) | (l.y << EmbeddingTiles::kShift) | l.x);
}

}  // namespace

EmbeddingTiles build_embedding_tiles(const ClosestPointEmbedding& E) {
  EmbeddingTiles T;
  const int size = 1 << EmbeddingTiles::kShift;
  T.dims = (E.grid.dims + size - 1) / size;
  struct Entry {
    uint64_t key;
    uint32_t cell, block;
  };
  std::vector<Entry> entries;
  entries.reserve(E.block_count());
  for (size_t slot = 0; slot < E.keys.size(); ++slot) {
    if (E.keys[slot] == ClosestPointEmbedding::kEmpty) continue;
    const uint32_t feature = uint32_t(E.keys[slot] & 0xffff);
    const glm::ivec3 cell = E.grid.voxel(size_t(E.keys[slot] >> 16));
    entries.push_back({tile_key(cell >> EmbeddingTiles::kShift, T.dims, feature), cell_in_tile(cell), E.blocks[slot]});
  }
  // Records in key order, so the table does not depend on the hash table's slot order. (No two entries are equal:
  // a cell holds one block per feature. So any sort gives this order.)
  tbb::parallel_sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    return a.key != b.key ? a.key < b.key : a.cell < b.cell;
  });
  std::vector<uint64_t> distinct;
  for (const Entry& e : entries) {
    if (distinct.empty() || distinct.back() != e.key) {
      distinct.push_back(e.key);
      T.cells.resize(T.cells.size() + EmbeddingTiles::kCells, EmbeddingTiles::kNoBlock);
    }
    T.cells[(distinct.size() - 1) * EmbeddingTiles::kCells + e.cell] = e.block;
  }
  build_hash_table(distinct, ClosestPointEmbedding::kMaxProbes, T.keys, T.tiles);
  return T;
}

int64_t EmbeddingTiles::find_block(const glm::ivec3& cell, uint32_t feature) const {
  const int64_t tile =
      find_in_hash_table(keys, tiles, tile_key(cell >> kShift, dims, feature), ClosestPointEmbedding::kMaxProbes);
  if (tile < 0) return -1;
  const uint32_t block = cells[size_t(tile) * kCells + cell_in_tile(cell)];
  return block == kNoBlock ? -1 : int64_t(block);
}

uint32_t GpuEmbedding::chunk_blocks_for(const gpu::Context& ctx, int sub, uint64_t max_chunk_bytes) {
  const uint64_t block_bytes = uint64_t(sub * sub * sub) * sizeof(glm::vec4);
  // A chunk is a buffer bound only as a texel buffer (gpu::MemoryUse::texels): within maxTexelBufferElements texels
  // and one allocation, not maxStorageBufferRange.
  const auto& d = ctx.info();
  uint64_t limit = d.max_texel_buffer_elements * sizeof(glm::vec4);
  if (d.max_memory_allocation_size) limit = std::min(limit, d.max_memory_allocation_size);
  if (max_chunk_bytes) limit = max_chunk_bytes;
  return uint32_t(std::max<uint64_t>(1, limit / block_bytes));
}

void GpuEmbedding::check_fits(const gpu::Context& ctx, size_t blocks, int sub, uint64_t max_chunk_bytes) {
  const uint64_t block_bytes = uint64_t(sub * sub * sub) * sizeof(glm::vec4);
  const uint32_t per_chunk = chunk_blocks_for(ctx, sub, max_chunk_bytes);
  if (blocks > size_t(per_chunk) * kFineChunks)
    throw gpu::Error("the closest point embedding has " + std::to_string(blocks) + " blocks (" +
                     gpu::format_bytes(blocks * block_bytes) + "); " + ctx.info().name + " binds at most " +
                     std::to_string(kFineChunks) + " x " + gpu::format_bytes(uint64_t(per_chunk) * block_bytes) +
                     "; use fewer subcells (--subcells), a coarser volume, or a device with a larger "
                     "maxTexelBufferElements and maxMemoryAllocationSize");
}

GpuEmbedding::GpuEmbedding(gpu::Context& ctx, const ClosestPointEmbedding& E, uint64_t max_chunk_bytes)
    : dims(E.grid.dims), sub(E.sub), spacing(E.grid.spacing) {
  const size_t total_blocks = E.block_count();
  check_fits(ctx, total_blocks, E.sub, max_chunk_bytes);
  const EmbeddingTiles T = build_embedding_tiles(E);
  // Every buffer of the embedding is read as texels only (shaders/shared/cp_lookup.glsl).
  constexpr auto texels = gpu::MemoryUse::texels;
  tile_keys = gpu::Buffer<uint64_t>(ctx, T.keys, "embedding tile keys", texels);
  tiles = gpu::Buffer<uint32_t>(ctx, T.tiles, "embedding tiles", texels);
  // An empty embedding still binds one (empty) cell.
  const std::vector<uint32_t> cells = T.cells.empty() ? std::vector<uint32_t>(1, EmbeddingTiles::kNoBlock) : T.cells;
  tile_cells = gpu::Buffer<uint32_t>(ctx, cells, "embedding tile cells", texels);
  table_mask = uint32_t(T.keys.size() - 1);
  chunk_blocks = chunk_blocks_for(ctx, E.sub, max_chunk_bytes);
  chunks = uint32_t(std::max<size_t>(1, (total_blocks + chunk_blocks - 1) / chunk_blocks));
  const size_t per_block = size_t(E.sub * E.sub * E.sub);
  for (int c = 0; c < kFineChunks; ++c) {
    const size_t first = std::min(total_blocks, size_t(c) * chunk_blocks);
    const size_t last = std::min(total_blocks, size_t(c + 1) * chunk_blocks);
    fine[size_t(c)] = gpu::Buffer<glm::vec4>(
        ctx, std::span<const glm::vec4>(E.fine.data() + first * per_block, (last - first) * per_block),
        "embedding fine points " + std::to_string(c), texels);
  }
}

void CpLookup::record(gpu::Sequence& seq, const GpuEmbedding& e, const gpu::Buffer<glm::vec4>& queries,
                      const gpu::Buffer<glm::vec4>& results, const gpu::Buffer<uint32_t>& valid, uint32_t n) const {
  if (n > queries.size() || n > results.size() || n > valid.size()) throw gpu::Error("cp lookup: n exceeds a buffer");
  struct {
    glm::ivec4 dims_sub;
    glm::vec4 spacing;
    uint32_t n, table_mask, chunk_blocks;
  } push{glm::ivec4(e.dims, e.sub), glm::vec4(e.spacing, 0.0f), n, e.table_mask, e.chunk_blocks};
  static_assert(sizeof(push) == 44);
  if (!kernel_ || spec_ != e.spec_constants()) {
    spec_ = e.spec_constants();
    kernel_.emplace(*ctx_, shaders::cp_lookup, spec_);
  }
  seq.dispatch(*kernel_,
               {e.tile_keys, e.tiles, e.tile_cells, e.fine[0], e.fine[1], e.fine[2], e.fine[3], queries, results, valid},
               push, n);
}

}  // namespace cpmesh::fields
