#pragma once
// Stream compaction on the GPU (Scan with as_flags, then shader compact_scatter; reference ref::compact):
// out receives, in their original order, values[i] (or i) for every i < n with flags[i] != 0, and count[count_index]
// their number. out must hold n values (the GPU does not know the count in advance).
#include "primitives/scan.h"

namespace cpmesh::gpu {

class Compact {
 public:
  explicit Compact(Context& ctx);
  void record(Sequence& seq, const Buffer<uint32_t>& flags, const Buffer<uint32_t>& values, uint32_t n,
              const Buffer<uint32_t>& out, const Buffer<uint32_t>& count, uint32_t count_index = 0) const;
  // The same, writing the indices i instead of values.
  void record_indices(Sequence& seq, const Buffer<uint32_t>& flags, uint32_t n, const Buffer<uint32_t>& out,
                      const Buffer<uint32_t>& count, uint32_t count_index = 0) const;

 private:
  void record_impl(Sequence& seq, const Buffer<uint32_t>& flags, const Buffer<uint32_t>* values, uint32_t n,
                   const Buffer<uint32_t>& out, const Buffer<uint32_t>& count, uint32_t count_index) const;
  Context* ctx_;
  Scan scan_;
  Kernel scatter_values_, scatter_indices_;
};

}  // namespace cpmesh::gpu
