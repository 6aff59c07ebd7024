#pragma once
// Exclusive prefix sum of uint32 on the GPU (shaders scan_blocks + scan_add; reference ref::exclusive_scan).
// Blocks of 1024 values are scanned in one dispatch; their totals are scanned recursively (one more level per factor
// 1024 in n) and added back. Sums wrap modulo 2^32, as in the reference.
#include "gpu/sequence.h"

namespace cpmesh::gpu {

class Scan {
 public:
  explicit Scan(Context& ctx);
  // dst[i] = sum of src[0..i) for i < n. dst may be src. When `as_flags`, each src[i] counts as (src[i] != 0).
  // When `total` is given, total[total_index] receives the sum of all n values.
  void record(Sequence& seq, const Buffer<uint32_t>& src, const Buffer<uint32_t>& dst, uint32_t n,
              bool as_flags = false, const Buffer<uint32_t>* total = nullptr, uint32_t total_index = 0) const;

  static constexpr uint32_t kBlock = 1024;

 private:
  Context* ctx_;
  Kernel blocks_, blocks_flags_, add_;
};

}  // namespace cpmesh::gpu
