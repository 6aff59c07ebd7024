#version 450
// Reduction (gpu::Reduce), one pass: each workgroup reduces 2048 values (256 threads x 8, strided by 256) to one.
// Compiled twice: reduce_f32 (-DTYPE_F32, float) and reduce_u32 (uint).
// Bindings: 0 src T[n]; 1 dst T[>= out_offset + ceil(n/2048)].
// Push: n, out_offset (dst index of workgroup 0's result). Spec constant 0 OP: 0 sum, 1 min, 2 max.
// Dispatch: ceil(n/2048) workgroups of 256; repeat until one value remains. Loops: 8 + 8 iterations.
// Reference: ref::reduce (float sums are summed in tree order here, so they match within rounding, not bitwise).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

#ifdef TYPE_F32
#define T float
#define T_MAX uintBitsToFloat(0x7f800000u)
#define T_MIN uintBitsToFloat(0xff800000u)
#else
#define T uint
#define T_MAX 0xffffffffu
#define T_MIN 0u
#endif

layout(local_size_x = 256) in;
layout(constant_id = 0) const uint OP = 0;
layout(std430, binding = 0) readonly buffer Src { T src[]; };
layout(std430, binding = 1) writeonly buffer Dst { T dst[]; };
layout(push_constant) uniform Push { uint n; uint out_offset; } pc;

const uint ITEMS = 8;
shared T partial[256];

T identity() { return OP == 0 ? T(0) : (OP == 1 ? T_MAX : T_MIN); }
T combine(T a, T b) { return OP == 0 ? a + b : (OP == 1 ? min(a, b) : max(a, b)); }

void main() {
  const uint block = flat_group_id();
  const uint tid = gl_LocalInvocationID.x;
  T acc = identity();
  for (uint k = 0; k < ITEMS; ++k) {
    const uint i = block * 256 * ITEMS + k * 256 + tid;
    if (i < pc.n) acc = combine(acc, src[i]);
  }
  partial[tid] = acc;
  barrier();
  for (uint stride = 128; stride > 0; stride >>= 1) {
    if (tid < stride) partial[tid] = combine(partial[tid], partial[tid + stride]);
    barrier();
  }
  if (tid == 0 && block * 256 * ITEMS < pc.n) dst[pc.out_offset + block] = partial[0];
}
