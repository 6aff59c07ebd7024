#pragma once
// Items grouped by key in one array (compressed rows): the items of key k are list[begin[k], begin[k + 1]), in
// ascending order. keys_of(item, add) calls add(key) for each key (< keys) of the item: any number, the same ones
// when called again; a key added twice for one item lists the item twice.
// Serves the vertex -> elements tables (elements_around.h), the triangle grid of crossing_triangles (quality.cpp) and
// the walls of split_material.
//
// A two-level counting sort, stable, so that the result is the same on any thread count: the items, in chunks, are
// first scattered by their keys' high bits into at most 2048 buckets (each chunk counts its own, so no two threads
// touch one counter), then each bucket, whose keys span at most keys / 1024, is sorted by the low bits in cache.
// The direct way, one counter per key bumped atomically from every thread, missed the cache on nearly every add: on
// a piece of 2.3 M tets (9.2 M adds over 1.6 M vertices) it took 1.5 s on one thread, this 0.1 s.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "host/host_array.h"

namespace cpmesh::mesh {

struct Grouped {
  std::vector<size_t> begin;  // keys + 1 offsets
  HostArray<uint32_t> list;  // (every entry written by the parallel fill: no serial zeroing first)
  std::span<const uint32_t> operator[](size_t k) const { return {list.data() + begin[k], list.data() + begin[k + 1]}; }
};

template <typename KeysOf>
Grouped group_by_key(size_t keys, size_t items, KeysOf&& keys_of) {
  Grouped g;
  g.begin.resize(keys + 1);
  g.begin[keys] = 0;
  if (keys == 0) return g;
  int bits = 0;
  while ((size_t(1) << bits) < keys) ++bits;
  const int shift = std::max(0, bits - 11);
  const size_t buckets = ((keys - 1) >> shift) + 1;
  const size_t chunk = std::max<size_t>(4096, (items + 255) / 256);
  const size_t chunks = (items + chunk - 1) / chunk;
  auto chunk_range = [&](size_t c) { return std::pair{c * chunk, std::min(items, (c + 1) * chunk)}; };
  // Each chunk's count per bucket, then where its items of each bucket go: buckets in order, chunks in order within.
  std::vector<size_t> at(chunks * buckets, 0);
  tbb::parallel_for(size_t(0), chunks, [&](size_t c) {
    size_t* mine = at.data() + c * buckets;
    const auto [first, last] = chunk_range(c);
    for (size_t i = first; i != last; ++i) keys_of(i, [&](size_t k) { ++mine[k >> shift]; });
  });
  std::vector<size_t> bucket_begin(buckets + 1);
  size_t total = 0;
  for (size_t b = 0; b < buckets; ++b) {
    bucket_begin[b] = total;
    for (size_t c = 0; c < chunks; ++c) total += std::exchange(at[c * buckets + b], total);
  }
  bucket_begin[buckets] = total;
  HostArray<std::array<uint32_t, 2>> scattered(total);  // (key, item)
  tbb::parallel_for(size_t(0), chunks, [&](size_t c) {
    size_t* mine = at.data() + c * buckets;
    const auto [first, last] = chunk_range(c);
    for (size_t i = first; i != last; ++i)
      keys_of(i, [&](size_t k) { scattered[mine[k >> shift]++] = {uint32_t(k), uint32_t(i)}; });
  });
  // Each bucket by its keys' low bits; its items stay in the order of the scatter, ascending.
  g.list.resize(total);
  g.begin[keys] = total;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, buckets, 1), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<size_t> next;
    for (size_t b = r.begin(); b != r.end(); ++b) {
      const size_t k0 = b << shift, width = std::min(keys, (b + 1) << shift) - k0;
      next.assign(width, 0);
      for (size_t e = bucket_begin[b]; e != bucket_begin[b + 1]; ++e) ++next[scattered[e][0] - k0];
      size_t at_key = bucket_begin[b];
      for (size_t j = 0; j < width; ++j) {
        g.begin[k0 + j] = at_key;
        at_key += std::exchange(next[j], at_key);
      }
      for (size_t e = bucket_begin[b]; e != bucket_begin[b + 1]; ++e)
        g.list[next[scattered[e][0] - k0]++] = scattered[e][1];
    }
  });
  return g;
}

}  // namespace cpmesh::mesh
