// Shared by radix_histogram.comp and radix_scatter.comp (gpu::RadixSort): 4-bit digits, blocks of 1024 keys
// (256 threads x 4 consecutive keys). KEY64 selects 64-bit keys stored as uvec2 (low word first, as uint64_t).
#ifndef CPMESH_RADIX_GLSL
#define CPMESH_RADIX_GLSL

const uint RADIX_BITS = 4;
const uint RADIX = 16;
const uint ITEMS = 4;
const uint BLOCK = 256 * ITEMS;

#ifdef KEY64
#define KEY uvec2
uint digit_of(uvec2 key, uint shift, uint mask) {
  // A 4-bit digit never straddles the two words: shifts are multiples of 4.
  return (shift < 32 ? (key.x >> shift) : (key.y >> (shift - 32))) & mask;
}
#else
#define KEY uint
uint digit_of(uint key, uint shift, uint mask) { return (key >> shift) & mask; }
#endif

#endif
