#pragma once
// Disjoint sets (union-find) over 0..n-1 that threads may join concurrently.
//
// A set's root is its smallest element, whatever the order of the joins: a root is only ever linked under a smaller
// root, so along any path the elements decrease and the smallest one of a set is never linked. Results that depend on
// the roots are then the same on any thread count. find() halves paths as it walks them; a halving only points an
// element at one of its ancestors, so concurrent halvings and joins leave every path leading to the same root.
// Used by the volume mesher's region seeds (every tet of the particles' Delaunay mesh), the cut's clusters of
// doubtful tets (split_material.h) and the sliver cavities (remesh_slivers.h).
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <utility>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "host/host_array.h"

namespace cpmesh {

class DisjointSets {
 public:
  explicit DisjointSets(size_t n) : parent_(n) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, size_t(1) << 14), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t i = r.begin(); i != r.end(); ++i) parent_[i] = uint32_t(i);
    });
  }
  size_t size() const { return parent_.size(); }

  // The root of x's set: its smallest element once every join has returned.
  uint32_t find(uint32_t x) {
    for (;;) {
      const uint32_t p = load(x);
      if (p == x) return x;
      const uint32_t g = load(p);
      if (g != p) std::atomic_ref<uint32_t>(parent_[x]).store(g, std::memory_order_relaxed);
      x = g;
    }
  }
  // Joins the sets of a and b; safe beside other joins and finds.
  void join(uint32_t a, uint32_t b) {
    for (;;) {
      a = find(a);
      b = find(b);
      if (a == b) return;
      if (a < b) std::swap(a, b);  // the larger root goes under the smaller
      uint32_t expected = a;
      if (std::atomic_ref<uint32_t>(parent_[a]).compare_exchange_strong(expected, b, std::memory_order_relaxed)) return;
    }
  }

 private:
  uint32_t load(uint32_t x) { return std::atomic_ref<uint32_t>(parent_[x]).load(std::memory_order_relaxed); }
  HostArray<uint32_t> parent_;
};

}  // namespace cpmesh
