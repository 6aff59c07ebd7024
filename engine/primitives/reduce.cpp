#include "primitives/reduce.h"

#include "cpmesh/shaders.h"

namespace cpmesh::gpu {

namespace {
constexpr uint32_t kF32Identity[3] = {0x00000000u, 0x7f800000u, 0xff800000u};  // 0, +inf, -inf
constexpr uint32_t kU32Identity[3] = {0u, 0xffffffffu, 0u};
}  // namespace

Reduce::Reduce(Context& ctx)
    : ctx_(&ctx),
      f32_{Kernel(ctx, shaders::reduce_f32, {0}), Kernel(ctx, shaders::reduce_f32, {1}),
           Kernel(ctx, shaders::reduce_f32, {2})},
      u32_{Kernel(ctx, shaders::reduce_u32, {0}), Kernel(ctx, shaders::reduce_u32, {1}),
           Kernel(ctx, shaders::reduce_u32, {2})} {}

void Reduce::record(Sequence& seq, ReduceOp op, const Buffer<float>& src, uint32_t n, const Buffer<float>& out,
                    uint32_t out_index) const {
  if (n > src.size() || out_index >= out.size()) throw Error("reduce: n or out_index outside the buffers");
  record_passes(seq, f32_[uint32_t(op)], src, n, out, out_index, kF32Identity[uint32_t(op)]);
}

void Reduce::record(Sequence& seq, ReduceOp op, const Buffer<uint32_t>& src, uint32_t n, const Buffer<uint32_t>& out,
                    uint32_t out_index) const {
  if (n > src.size() || out_index >= out.size()) throw Error("reduce: n or out_index outside the buffers");
  record_passes(seq, u32_[uint32_t(op)], src, n, out, out_index, kU32Identity[uint32_t(op)]);
}

void Reduce::record_passes(Sequence& seq, const Kernel& kernel, const BufferBase& src, uint32_t n,
                           const BufferBase& out, uint32_t out_index, uint32_t identity_bits) const {
  if (n == 0) {
    seq.copy(Buffer<uint32_t>(*ctx_, std::vector<uint32_t>{identity_bits}, "reduce identity"), out, 4, 0,
             4ull * out_index);
    return;
  }
  struct {
    uint32_t n, out_offset;
  } push{n, 0};
  BufferBase current = src;
  while (true) {
    const uint32_t groups = (push.n + kPerGroup - 1) / kPerGroup;
    if (groups == 1) {
      push.out_offset = out_index;
      seq.dispatch(kernel, {current, out}, push, 256);
      return;
    }
    BufferBase partial(*ctx_, 4ull * groups, "reduce partials");
    seq.dispatch(kernel, {current, partial}, push, uint64_t(groups) * 256).barrier();
    current = partial;
    push.n = groups;
  }
}

}  // namespace cpmesh::gpu
