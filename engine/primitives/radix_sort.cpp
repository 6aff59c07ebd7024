#include "primitives/radix_sort.h"

#include <algorithm>

#include "cpmesh/shaders.h"

namespace cpmesh::gpu {

RadixSort::RadixSort(Context& ctx)
    : ctx_(&ctx),
      scan_(ctx),
      histogram32_(ctx, shaders::radix_histogram_u32),
      histogram64_(ctx, shaders::radix_histogram_u64),
      scatter32_(ctx, shaders::radix_scatter_u32),
      scatter64_(ctx, shaders::radix_scatter_u64) {}

void RadixSort::record(Sequence& seq, const Buffer<uint32_t>& keys, const Buffer<uint32_t>& values, uint32_t n,
                       uint32_t key_bits, uint32_t first_bit) const {
  if (key_bits + first_bit > 32)
    throw Error("radix sort of 32-bit keys by bits " + std::to_string(first_bit) + " + " + std::to_string(key_bits));
  if (n > keys.size()) throw Error("radix sort: n exceeds the keys buffer");
  record_passes(seq, false, keys, values, n, key_bits, first_bit);
}

void RadixSort::record(Sequence& seq, const Buffer<uint64_t>& keys, const Buffer<uint32_t>& values, uint32_t n,
                       uint32_t key_bits, uint32_t first_bit) const {
  if (key_bits + first_bit > 64)
    throw Error("radix sort of 64-bit keys by bits " + std::to_string(first_bit) + " + " + std::to_string(key_bits));
  if (n > keys.size()) throw Error("radix sort: n exceeds the keys buffer");
  record_passes(seq, true, keys, values, n, key_bits, first_bit);
}

void RadixSort::record_passes(Sequence& seq, bool key64, const BufferBase& keys, const Buffer<uint32_t>& values,
                              uint32_t n, uint32_t key_bits, uint32_t first_bit) const {
  if (n > values.size()) throw Error("radix sort: n exceeds the values buffer");
  const uint32_t passes = (key_bits + kDigitBits - 1) / kDigitBits;
  if (n <= 1 || passes == 0) return;
  const uint64_t key_bytes = key64 ? 8 : 4;
  const uint32_t blocks = (n + kBlock - 1) / kBlock;
  BufferBase keys_tmp(*ctx_, key_bytes * n, "radix keys (ping-pong)");
  Buffer<uint32_t> values_tmp(*ctx_, n, "radix values (ping-pong)");
  Buffer<uint32_t> hist(*ctx_, size_t(blocks) * 16, "radix histogram");
  const Kernel& histogram = key64 ? histogram64_ : histogram32_;
  const Kernel& scatter = key64 ? scatter64_ : scatter32_;
  const BufferBase* key_src = &keys;
  const BufferBase* key_dst = &keys_tmp;
  const Buffer<uint32_t>* val_src = &values;
  const Buffer<uint32_t>* val_dst = &values_tmp;
  for (uint32_t pass = 0; pass < passes; ++pass) {
    const uint32_t shift = first_bit + pass * kDigitBits;
    const uint32_t bits = std::min(kDigitBits, first_bit + key_bits - shift);  // the last pass may take fewer bits
    const struct {
      uint32_t n, shift, n_blocks, digit_mask;
    } push{n, shift, blocks, (1u << bits) - 1};
    seq.dispatch(histogram, {*key_src, hist}, push, uint64_t(blocks) * histogram.workgroup_size()).barrier();
    scan_.record(seq, hist, hist, blocks * 16);
    seq.barrier().dispatch(scatter, {*key_src, *val_src, *key_dst, *val_dst, hist}, push,
                          uint64_t(blocks) * scatter.workgroup_size());
    seq.barrier();
    std::swap(key_src, key_dst);
    std::swap(val_src, val_dst);
  }
  if (key_src != &keys) {  // odd number of passes: the result is in the temporaries
    seq.copy(*key_src, keys, key_bytes * n).copy(*val_src, values, 4ull * n).barrier();
  }
}

}  // namespace cpmesh::gpu
