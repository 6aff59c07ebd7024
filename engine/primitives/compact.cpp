#include "primitives/compact.h"

#include "cpmesh/shaders.h"

namespace cpmesh::gpu {

Compact::Compact(Context& ctx)
    : ctx_(&ctx),
      scan_(ctx),
      scatter_values_(ctx, shaders::compact_scatter, {0}),
      scatter_indices_(ctx, shaders::compact_scatter, {1}) {}

void Compact::record(Sequence& seq, const Buffer<uint32_t>& flags, const Buffer<uint32_t>& values, uint32_t n,
                     const Buffer<uint32_t>& out, const Buffer<uint32_t>& count, uint32_t count_index) const {
  if (n > values.size()) throw Error("compact: n exceeds the values buffer");
  record_impl(seq, flags, &values, n, out, count, count_index);
}

void Compact::record_indices(Sequence& seq, const Buffer<uint32_t>& flags, uint32_t n, const Buffer<uint32_t>& out,
                             const Buffer<uint32_t>& count, uint32_t count_index) const {
  record_impl(seq, flags, nullptr, n, out, count, count_index);
}

void Compact::record_impl(Sequence& seq, const Buffer<uint32_t>& flags, const Buffer<uint32_t>* values, uint32_t n,
                          const Buffer<uint32_t>& out, const Buffer<uint32_t>& count, uint32_t count_index) const {
  if (n > flags.size() || n > out.size() || count_index >= count.size())
    throw Error("compact: n or count_index outside the buffers");
  Buffer<uint32_t> offsets(*ctx_, n, "compact offsets");
  // The scan's total is the kept count; the scatter kernel then only places the items.
  scan_.record(seq, flags, offsets, n, true, &count, count_index);
  if (n == 0) return;
  const struct { uint32_t n; } push{n};
  seq.barrier();
  if (values)
    seq.dispatch(scatter_values_, {flags, offsets, *values, out}, push, n);
  else
    seq.dispatch(scatter_indices_, {flags, offsets, flags, out}, push, n);
}

}  // namespace cpmesh::gpu
