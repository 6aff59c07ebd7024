#version 450
// Exclusive prefix sum, phase 2 of 2 (gpu::Scan): adds each block's scanned offset to the block-local scan.
// Bindings: 0 data uint[n] (block-local exclusive scan, updated in place); 1 block_offsets uint[ceil(n/1024)]
//           (exclusive scan of the block totals).
// Push: n. Dispatch: ceil(n/1024) workgroups of 256 (4 items each). Reference: ref::exclusive_scan.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = 256) in;
layout(std430, binding = 0) buffer Data { uint data[]; };
layout(std430, binding = 1) readonly buffer Offsets { uint block_offsets[]; };
layout(push_constant) uniform Push { uint n; } pc;

const uint ITEMS = 4;
const uint BLOCK = 256 * ITEMS;

void main() {
  const uint block = flat_group_id();
  const uint base = block * BLOCK + gl_LocalInvocationID.x * ITEMS;
  if (base >= pc.n) return;  // no barrier below
  const uint offset = block_offsets[block];
  for (uint k = 0; k < ITEMS; ++k)
    if (base + k < pc.n) data[base + k] += offset;
}
