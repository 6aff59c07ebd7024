#version 450
// Radix sort pass, step 1 of 3 (gpu::RadixSort): per block of 1024 keys, count each 4-bit digit at `shift`.
// Compiled as radix_histogram_u32 and radix_histogram_u64 (-DKEY64).
// Bindings: 0 keys KEY[n]; 1 hist uint[16 * n_blocks], digit-major (hist[d * n_blocks + block]) so that one
//           exclusive scan of hist gives every (digit, block) its global output offset.
// Push: n, shift, n_blocks, digit_mask (15, or fewer bits in the last pass when key_bits is not a multiple of 4).
// Dispatch: n_blocks workgroups of 256. Loops: 4 iterations. Reference: ref::radix_sort.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "radix.glsl"

layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Keys { KEY keys[]; };
layout(std430, binding = 1) writeonly buffer Hist { uint hist[]; };
layout(push_constant) uniform Push { uint n; uint shift; uint n_blocks; uint digit_mask; } pc;

shared uint counts[RADIX];

void main() {
  const uint block = flat_group_id();
  const uint tid = gl_LocalInvocationID.x;
  if (tid < RADIX) counts[tid] = 0;
  barrier();
  const uint base = block * BLOCK + tid * ITEMS;
  for (uint k = 0; k < ITEMS; ++k)
    if (base + k < pc.n) atomicAdd(counts[digit_of(keys[base + k], pc.shift, pc.digit_mask)], 1u);
  barrier();
  if (tid < RADIX && block < pc.n_blocks) hist[tid * pc.n_blocks + block] = counts[tid];
}
