#version 450
// Exclusive prefix sum, phase 1 of 2 (gpu::Scan): each workgroup scans one block of 1024 uints (256 threads x 4
// consecutive items), writes the block-local exclusive scan to dst and the block's total to block_sums.
// Bindings: 0 src uint[n]; 1 dst uint[n] (may be src: each thread reads its items before any write); 2 block_sums
//           uint[ceil(n/1024)].
// Push: n. Spec constant 0 AS_FLAGS: when 1, src[i] counts as (src[i] != 0) instead of its value (stream compaction).
// Dispatch: ceil(n/1024) workgroups of 256. Loops: 4 + 8 iterations per invocation.
// Reference: ref::exclusive_scan.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = 256) in;
layout(constant_id = 0) const uint AS_FLAGS = 0;
layout(std430, binding = 0) readonly buffer Src { uint src[]; };
layout(std430, binding = 1) writeonly buffer Dst { uint dst[]; };
layout(std430, binding = 2) writeonly buffer Sums { uint block_sums[]; };
layout(push_constant) uniform Push { uint n; } pc;

const uint ITEMS = 4;
const uint BLOCK = 256 * ITEMS;
shared uint partial[256];

void main() {
  const uint block = flat_group_id();
  const uint tid = gl_LocalInvocationID.x;
  const uint base = block * BLOCK + tid * ITEMS;
  uint before_in_thread[ITEMS];
  uint total = 0;
  for (uint k = 0; k < ITEMS; ++k) {
    uint x = 0;
    if (base + k < pc.n) x = src[base + k];
    if (AS_FLAGS != 0) x = x != 0 ? 1u : 0u;
    before_in_thread[k] = total;
    total += x;
  }
  partial[tid] = total;
  barrier();
  for (uint offset = 1; offset < 256; offset <<= 1) {  // Hillis-Steele inclusive scan of the thread totals
    const uint add = tid >= offset ? partial[tid - offset] : 0u;
    barrier();
    partial[tid] += add;
    barrier();
  }
  const uint before_thread = partial[tid] - total;
  for (uint k = 0; k < ITEMS; ++k)
    if (base + k < pc.n) dst[base + k] = before_thread + before_in_thread[k];
  if (tid == 255 && block * BLOCK < pc.n) block_sums[block] = partial[255];
}
