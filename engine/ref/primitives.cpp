#include "ref/primitives.h"

#include <algorithm>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace cpmesh::ref {

std::vector<uint32_t> exclusive_scan(std::span<const uint32_t> src, bool as_flags) {
  std::vector<uint32_t> dst(src.size());
  uint32_t sum = 0;
  for (size_t i = 0; i < src.size(); ++i) {
    dst[i] = sum;
    sum += as_flags ? uint32_t(src[i] != 0) : src[i];
  }
  return dst;
}

double reduce(std::span<const float> src, uint32_t op) {
  if (op == 0) return std::accumulate(src.begin(), src.end(), 0.0);
  if (src.empty()) return op == 1 ? std::numeric_limits<float>::infinity() : -std::numeric_limits<float>::infinity();
  return op == 1 ? *std::min_element(src.begin(), src.end()) : *std::max_element(src.begin(), src.end());
}

uint32_t reduce(std::span<const uint32_t> src, uint32_t op) {
  if (op == 0) return std::accumulate(src.begin(), src.end(), uint32_t(0));
  if (src.empty()) return op == 1 ? std::numeric_limits<uint32_t>::max() : 0u;
  return op == 1 ? *std::min_element(src.begin(), src.end()) : *std::max_element(src.begin(), src.end());
}

std::vector<uint32_t> compact(std::span<const uint32_t> flags, std::span<const uint32_t> values) {
  std::vector<uint32_t> out;
  for (size_t i = 0; i < flags.size(); ++i)
    if (flags[i] != 0) out.push_back(values.empty() ? uint32_t(i) : values[i]);
  return out;
}

namespace {
template <class K>
void sort_pairs(std::vector<K>& keys, std::vector<uint32_t>& values, uint32_t key_bits, uint32_t first_bit) {
  if (keys.size() != values.size()) throw std::invalid_argument("ref::radix_sort: keys and values differ in size");
  const K mask = key_bits >= 8 * sizeof(K) ? ~K(0) : (K(1) << key_bits) - 1;
  std::vector<size_t> order(keys.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return ((keys[a] >> first_bit) & mask) < ((keys[b] >> first_bit) & mask); });
  std::vector<K> k(keys.size());
  std::vector<uint32_t> v(values.size());
  for (size_t i = 0; i < order.size(); ++i) {
    k[i] = keys[order[i]];
    v[i] = values[order[i]];
  }
  keys.swap(k);
  values.swap(v);
}
}  // namespace

void radix_sort(std::vector<uint32_t>& keys, std::vector<uint32_t>& values, uint32_t key_bits, uint32_t first_bit) {
  sort_pairs(keys, values, key_bits, first_bit);
}
void radix_sort(std::vector<uint64_t>& keys, std::vector<uint32_t>& values, uint32_t key_bits, uint32_t first_bit) {
  sort_pairs(keys, values, key_bits, first_bit);
}

}  // namespace cpmesh::ref
