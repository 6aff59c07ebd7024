#pragma once
// Items grouped by key in one array (compressed rows): the items of key k are list[begin[k], begin[k + 1]). Built by
// a parallel counting sort: keys_of(item, add) calls add(key) for each key of the item (any number, the same ones
// when called again). Within a key the items are in ascending order where `ascending`, else in any order.
// Serves the vertex -> elements tables (elements_around.h) and the triangle grid of crossing_triangles (quality.cpp).
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <span>
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
Grouped group_by_key(size_t keys, size_t items, KeysOf&& keys_of, bool ascending) {
  Grouped g;
  g.begin.assign(keys + 1, 0);
  std::vector<std::atomic<size_t>> next(keys);
  const tbb::blocked_range<size_t> all(0, items, 4096);
  tbb::parallel_for(all, [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i)
      keys_of(i, [&](size_t k) { next[k].fetch_add(1, std::memory_order_relaxed); });
  });
  for (size_t k = 0; k < keys; ++k) g.begin[k + 1] = g.begin[k] + next[k].load(std::memory_order_relaxed);
  for (size_t k = 0; k < keys; ++k) next[k].store(g.begin[k], std::memory_order_relaxed);
  g.list.resize(g.begin[keys]);
  tbb::parallel_for(all, [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i)
      keys_of(i, [&](size_t k) { g.list[next[k].fetch_add(1, std::memory_order_relaxed)] = uint32_t(i); });
  });
  if (ascending)
    tbb::parallel_for(tbb::blocked_range<size_t>(0, keys), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t k = r.begin(); k != r.end(); ++k) std::sort(g.list.begin() + g.begin[k], g.list.begin() + g.begin[k + 1]);
    });
  return g;
}

}  // namespace cpmesh::mesh
