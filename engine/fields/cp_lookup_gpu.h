#pragma once
// The closest point embedding on the GPU and the batch lookup kernel (shaders/cp_lookup.comp). The particle system
// binds the same buffers and includes shaders/shared/cp_lookup.glsl in its advection kernel.
#include <array>
#include <optional>
#include <vector>

#include "fields/closest_point_embedding.h"
#include "gpu/sequence.h"

namespace cpmesh::fields {

// The GPU's coarse index: the embedding's (cell, feature) -> block table regrouped by tiles of 4^3 cells. A lookup's
// stencil covers 8-27 cells (15.6 on average) but only 1-8 tiles (2.6 on average), and on lavapipe the hash finds,
// not the WENO arithmetic, were most of a lookup's cost (0.37 M lookups/s with them, 0.87 without; issue 9).
// Built on the host from ClosestPointEmbedding::keys/blocks; find_block answers as ClosestPointEmbedding::find_block.
struct EmbeddingTiles {
  static constexpr int kShift = 2;             // tiles of 2^kShift cells per axis (shaders/shared/cp_lookup.glsl)
  static constexpr uint32_t kCells = 64;       // cells per tile, x fastest
  static constexpr uint32_t kNoBlock = ~0u;    // a tile cell without a block of the tile's feature
  glm::ivec3 dims{0};                          // tiles per axis
  std::vector<uint64_t> keys;                  // hash table (build_hash_table) of tile index << 16 | feature
  std::vector<uint32_t> tiles;                 // slot -> tile record
  std::vector<uint32_t> cells;                 // kCells per record: the block of each cell, or kNoBlock
  int64_t find_block(const glm::ivec3& cell, uint32_t feature) const;
  size_t memory_bytes() const { return keys.size() * 8 + tiles.size() * 4 + cells.size() * 4; }
};
EmbeddingTiles build_embedding_tiles(const ClosestPointEmbedding& embedding);

// The fine points are split over kFineChunks buffers of whole blocks, each within maxStorageBufferRange (128 MiB on
// lavapipe) and maxTexelBufferElements RGBA32F texels, so an embedding of up to four times that size can be bound.
// The shaders read them as uniform texel buffers (samplerBuffer): lavapipe gathers a texel for all lanes at once
// where it loads a storage buffer's vec4 lane by lane and component by component; the batch lookup on lavapipe
// (bench-fields, 2 M lookups, wedge ball) went from 0.40-0.51 to 1.34-1.59 M lookups/s, results bit for bit the same.
// The tile keys, records and cells are read as RGBA32UI texels too (two keys, four records or four cells a texel):
// about 15% more lookups a second again.
struct GpuEmbedding {
  static constexpr int kFineChunks = 4;
  // max_chunk_bytes: 0 = the device's limits (above); tests lower it to exercise the split on small data.
  GpuEmbedding(gpu::Context& ctx, const ClosestPointEmbedding& embedding, uint64_t max_chunk_bytes = 0);
  // Throws gpu::Error, naming the blocks, their bytes and the device's limit, where an embedding of `blocks` blocks
  // at `sub` subcells does not fit kFineChunks buffers of the device (EmbeddingOptions::check_blocks).
  static void check_fits(const gpu::Context& ctx, size_t blocks, int sub, uint64_t max_chunk_bytes = 0);
  // Blocks per fine chunk at `sub`: the device's binding limits, or max_chunk_bytes where given.
  static uint32_t chunk_blocks_for(const gpu::Context& ctx, int sub, uint64_t max_chunk_bytes = 0);
  // EmbeddingTiles on the device: keys read as uvec2 (low word first), two per texel.
  gpu::Buffer<uint64_t> tile_keys;
  gpu::Buffer<uint32_t> tiles, tile_cells;
  std::array<gpu::Buffer<glm::vec4>, kFineChunks> fine;
  uint32_t chunk_blocks = 0;      // blocks per fine chunk
  uint32_t chunks = 1;            // fine buffers that hold blocks (1..kFineChunks)
  glm::ivec3 dims;
  int sub;
  glm::vec3 spacing;
  uint32_t table_mask;
  // Specialization constants of every kernel that includes shaders/shared/cp_lookup.glsl: sub, chunks.
  std::vector<uint32_t> spec_constants() const { return {uint32_t(sub), chunks}; }
};

class CpLookup {
 public:
  explicit CpLookup(gpu::Context& ctx) : ctx_(&ctx) {}
  // queries: xyz local position, w = the feature id's bits (glm::uintBitsToFloat). results: closest point + sizing.
  void record(gpu::Sequence& seq, const GpuEmbedding& embedding, const gpu::Buffer<glm::vec4>& queries,
              const gpu::Buffer<glm::vec4>& results, const gpu::Buffer<uint32_t>& valid, uint32_t n) const;

 private:
  gpu::Context* ctx_;
  // The kernel specialised for the last embedding's GpuEmbedding::spec_constants (rebuilt when they change).
  mutable std::vector<uint32_t> spec_;
  mutable std::optional<gpu::Kernel> kernel_;
};

}  // namespace cpmesh::fields
