#include "primitives/scan.h"

#include "cpmesh/shaders.h"

namespace cpmesh::gpu {

Scan::Scan(Context& ctx)
    : ctx_(&ctx),
      blocks_(ctx, shaders::scan_blocks, {0}),
      blocks_flags_(ctx, shaders::scan_blocks, {1}),
      add_(ctx, shaders::scan_add) {}

void Scan::record(Sequence& seq, const Buffer<uint32_t>& src, const Buffer<uint32_t>& dst, uint32_t n, bool as_flags,
                  const Buffer<uint32_t>* total, uint32_t total_index) const {
  if (n > src.size() || n > dst.size())
    throw Error("scan of " + std::to_string(n) + " values with buffers of " + std::to_string(src.size()) + " and " +
                std::to_string(dst.size()));
  if (total && total_index >= total->size()) throw Error("scan total index outside its buffer");
  if (n == 0) {
    if (total) seq.copy(Buffer<uint32_t>(*ctx_, std::vector<uint32_t>{0}, "scan zero"), *total, 4, 0, 4ull * total_index);
    return;
  }
  const uint32_t blocks = (n + kBlock - 1) / kBlock;
  Buffer<uint32_t> sums(*ctx_, blocks, "scan block sums");
  const struct { uint32_t n; } push{n};
  seq.dispatch(as_flags ? blocks_flags_ : blocks_, {src, dst, sums}, push, uint64_t(blocks) * 256).barrier();
  if (blocks > 1) {
    record(seq, sums, sums, blocks, false, total, total_index);
    seq.barrier().dispatch(add_, {dst, sums}, push, uint64_t(blocks) * 256);
  } else if (total) {
    seq.copy(sums, *total, 4, 0, 4ull * total_index);
  }
}

}  // namespace cpmesh::gpu
