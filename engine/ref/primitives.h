#pragma once
// C++ references for the building-block shaders: the plain, obvious algorithm each GPU primitive is tested against.
#include <cstdint>
#include <span>
#include <vector>

namespace cpmesh::ref {

// dst[i] = sum of src[0..i) modulo 2^32; as_flags counts src[i] != 0 as 1.   (shaders scan_blocks + scan_add)
std::vector<uint32_t> exclusive_scan(std::span<const uint32_t> src, bool as_flags = false);

// Sum (accumulated in double), min or max; op 0 sum, 1 min, 2 max; empty input gives the identity.  (reduce_*)
double reduce(std::span<const float> src, uint32_t op);
uint32_t reduce(std::span<const uint32_t> src, uint32_t op);

// values[i] (or i when values is empty) for every i with flags[i] != 0, in order.   (compact_scatter)
std::vector<uint32_t> compact(std::span<const uint32_t> flags, std::span<const uint32_t> values);

// Stable sort of (key, value) pairs by the low key_bits bits of the key.   (radix_histogram_* + radix_scatter_*)
void radix_sort(std::vector<uint32_t>& keys, std::vector<uint32_t>& values, uint32_t key_bits = 32,
                uint32_t first_bit = 0);
void radix_sort(std::vector<uint64_t>& keys, std::vector<uint32_t>& values, uint32_t key_bits = 64,
                uint32_t first_bit = 0);

}  // namespace cpmesh::ref
