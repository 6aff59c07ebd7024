#pragma once
// Sum, min and max of float or uint32 arrays on the GPU (shaders reduce_f32 / reduce_u32; reference ref::reduce).
// Each pass reduces 2048 values per workgroup; passes repeat until one value remains. Empty input gives the
// identity: 0 for sums, +inf / UINT32_MAX for min, -inf / 0 for max.
#include "gpu/sequence.h"

namespace cpmesh::gpu {

enum class ReduceOp : uint32_t { sum = 0, min = 1, max = 2 };

class Reduce {
 public:
  explicit Reduce(Context& ctx);
  // out[out_index] = op over src[0..n). Several reductions can share one small readback buffer.
  void record(Sequence& seq, ReduceOp op, const Buffer<float>& src, uint32_t n, const Buffer<float>& out,
              uint32_t out_index = 0) const;
  void record(Sequence& seq, ReduceOp op, const Buffer<uint32_t>& src, uint32_t n, const Buffer<uint32_t>& out,
              uint32_t out_index = 0) const;

  static constexpr uint32_t kPerGroup = 2048;

 private:
  void record_passes(Sequence& seq, const Kernel& kernel, const BufferBase& src, uint32_t n, const BufferBase& out,
                     uint32_t out_index, uint32_t identity_bits) const;
  Context* ctx_;
  Kernel f32_[3], u32_[3];
};

}  // namespace cpmesh::gpu
