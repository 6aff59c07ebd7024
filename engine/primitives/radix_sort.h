#pragma once
// Stable LSD radix sort of 32-bit or 64-bit keys with a uint32 payload on the GPU (shaders radix_histogram_*,
// radix_scatter_* and the Scan; reference ref::radix_sort). 4-bit digits: one pass per 4 key bits, each pass a
// histogram per block of 1024 keys, one exclusive scan of the digit-major histogram, and a stable scatter.
// Only key_bits bits from first_bit up take part (Morton codes: 30 or 63, or their top 3 x depth bits); the other
// bits are carried along but not sorted by.
#include "primitives/scan.h"

namespace cpmesh::gpu {

class RadixSort {
 public:
  explicit RadixSort(Context& ctx);
  // Sorts keys[0..n) and values[0..n) in place (through temporary buffers).
  void record(Sequence& seq, const Buffer<uint32_t>& keys, const Buffer<uint32_t>& values, uint32_t n,
              uint32_t key_bits = 32, uint32_t first_bit = 0) const;
  void record(Sequence& seq, const Buffer<uint64_t>& keys, const Buffer<uint32_t>& values, uint32_t n,
              uint32_t key_bits = 64, uint32_t first_bit = 0) const;

  static constexpr uint32_t kBlock = 1024;
  static constexpr uint32_t kDigitBits = 4;

 private:
  void record_passes(Sequence& seq, bool key64, const BufferBase& keys, const Buffer<uint32_t>& values, uint32_t n,
                     uint32_t key_bits, uint32_t first_bit) const;
  Context* ctx_;
  Scan scan_;
  Kernel histogram32_, histogram64_, scatter32_, scatter64_;
};

}  // namespace cpmesh::gpu
