#version 450
// Radix sort pass, step 3 of 3 (gpu::RadixSort): stable scatter of keys and payload by the 4-bit digit at `shift`.
// Each key's output position = offsets[digit * n_blocks + block] (scanned histogram) + the number of equal digits
// before it in its block. That rank comes from one block-wide scan of per-thread digit counts packed as 16 x 16-bit
// counters in 8 uints (a block holds at most 1024 keys, so no counter overflows).
// Compiled as radix_scatter_u32 and radix_scatter_u64 (-DKEY64).
// Bindings: 0 keys_in KEY[n]; 1 values_in uint[n]; 2 keys_out KEY[n]; 3 values_out uint[n]; 4 offsets uint[16*n_blocks].
// Push: n, shift, n_blocks, digit_mask (15, or fewer bits in the last pass when key_bits is not a multiple of 4).
// Dispatch: n_blocks workgroups of 64. Loops: 16 + 6 x 8 + 16 iterations.
// Reference: ref::radix_sort.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "radix.glsl"

// 64 threads x 16 consecutive keys: the serial per-thread ranking is cheap, and the block-wide scan (the costly,
// barrier-bound part) runs over 64 threads instead of 256: 2.5x faster on lavapipe than 256 x 4. 32 threads measured
// faster still there, but would leave half of an AMD wave64 idle.
const uint THREADS = 64;
const uint PER_THREAD = BLOCK / THREADS;

layout(local_size_x = THREADS) in;
layout(std430, binding = 0) readonly buffer KeysIn { KEY keys_in[]; };
layout(std430, binding = 1) readonly buffer ValuesIn { uint values_in[]; };
layout(std430, binding = 2) writeonly buffer KeysOut { KEY keys_out[]; };
layout(std430, binding = 3) writeonly buffer ValuesOut { uint values_out[]; };
layout(std430, binding = 4) readonly buffer Offsets { uint offsets[]; };
layout(push_constant) uniform Push { uint n; uint shift; uint n_blocks; uint digit_mask; } pc;

const uint WORDS = RADIX / 2;        // two 16-bit counters per uint
shared uint packed[WORDS * THREADS];  // [word][thread]: 2 KiB
shared uint digit_base[RADIX];

uint counter(uint words[WORDS], uint d) { return (words[d >> 1] >> ((d & 1) * 16)) & 0xffffu; }

void main() {
  const uint block = flat_group_id();
  const uint tid = gl_LocalInvocationID.x;
  const uint base = block * BLOCK + tid * PER_THREAD;
  if (tid < RADIX && block < pc.n_blocks) digit_base[tid] = offsets[tid * pc.n_blocks + block];

  KEY key[PER_THREAD];
  uint digit[PER_THREAD];
  uint rank_in_thread[PER_THREAD];
  uint mine[WORDS];
  for (uint w = 0; w < WORDS; ++w) mine[w] = 0;
  for (uint k = 0; k < PER_THREAD; ++k) {
    digit[k] = 0;
    rank_in_thread[k] = 0;
    if (base + k < pc.n) {
      key[k] = keys_in[base + k];
      const uint d = digit_of(key[k], pc.shift, pc.digit_mask);
      digit[k] = d;
      rank_in_thread[k] = counter(mine, d);
      mine[d >> 1] += 1u << ((d & 1) * 16);
    }
  }
  for (uint w = 0; w < WORDS; ++w) packed[w * THREADS + tid] = mine[w];
  barrier();
  for (uint offset = 1; offset < THREADS; offset <<= 1) {  // Hillis-Steele inclusive scan, 8 counters per word
    uint add[WORDS];
    for (uint w = 0; w < WORDS; ++w) add[w] = tid >= offset ? packed[w * THREADS + tid - offset] : 0u;
    barrier();
    for (uint w = 0; w < WORDS; ++w) packed[w * THREADS + tid] += add[w];
    barrier();
  }
  uint before[WORDS];  // exclusive: equal digits in earlier threads of this block
  for (uint w = 0; w < WORDS; ++w) before[w] = packed[w * THREADS + tid] - mine[w];
  for (uint k = 0; k < PER_THREAD; ++k) {
    if (base + k < pc.n) {
      const uint pos = digit_base[digit[k]] + counter(before, digit[k]) + rank_in_thread[k];
      keys_out[pos] = key[k];
      values_out[pos] = values_in[base + k];
    }
  }
}
