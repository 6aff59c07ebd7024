#pragma once
// Large host arrays whose memory is first touched by the threads that fill them.
//
// The kernel maps a large allocation's pages, and zeroes them, at their first write. std::vector<T>(n) writes every
// element on the calling thread before any parallel loop runs, so for arrays of hundreds of MiB that thread spends
// its time in page faults while the others wait. perf on the fields of the 199x250x249 head phantom at --max-size
// 0.5 (2-core VM) found most of the stage's single-threaded time there: the sizing field's 194 MiB arrays of 3x3
// forms (seven of them), the indicator fields' per-material distance arrays, the embedding's 350 MiB of fine points.
// The mesh stages use it too (the element tables of mesh/grouped.h, crossing_triangles' boxes).
//
// HostArray<T> leaves trivially constructible elements uninitialised when sized or resized: the loop that writes
// every element touches the pages, in parallel. filled() gives n copies of a value, written in parallel.
#include <algorithm>
#include <cstddef>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace cpmesh {

// std::allocator, except that a value-initialised element (vector(n), resize(n)) is default-initialised instead.
template <class T>
struct DefaultInitAllocator : std::allocator<T> {
  using value_type = T;
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() noexcept = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};
template <class T, class U>
bool operator==(const DefaultInitAllocator<T>&, const DefaultInitAllocator<U>&) noexcept {
  return true;
}

template <class T>
using HostArray = std::vector<T, DefaultInitAllocator<T>>;

// n copies of value, written by every thread.
template <class T>
HostArray<T> filled(size_t n, const T& value) {
  static_assert(std::is_trivially_default_constructible_v<T> && std::is_trivially_copyable_v<T>);
  HostArray<T> a(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, size_t(1) << 14), [&](const tbb::blocked_range<size_t>& r) {
    std::fill(a.data() + r.begin(), a.data() + r.end(), value);
  });
  return a;
}

// to = from, written by every thread.
template <class T>
void copy_into(HostArray<T>& to, const HostArray<T>& from) {
  to.resize(from.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, from.size(), size_t(1) << 14),
                    [&](const tbb::blocked_range<size_t>& r) {
                      std::copy(from.data() + r.begin(), from.data() + r.end(), to.data() + r.begin());
                    });
}

// What visit(k, out) appends to `out` for every k in [0, count), the k's in parallel, concatenated in k order: what
// one loop over k gives (e.g. k a z layer of voxels).
template <class T, class Visit>
std::vector<T> collect_in_order(int count, Visit&& visit) {
  std::vector<std::vector<T>> parts(size_t(std::max(count, 0)));
  tbb::parallel_for(tbb::blocked_range<int>(0, std::max(count, 0)), [&](const tbb::blocked_range<int>& r) {
    for (int k = r.begin(); k < r.end(); ++k) visit(k, parts[size_t(k)]);
  });
  size_t total = 0;
  for (const auto& part : parts) total += part.size();
  std::vector<T> all;
  all.reserve(total);
  for (auto& part : parts) {
    all.insert(all.end(), part.begin(), part.end());
    std::vector<T>().swap(part);
  }
  return all;
}

// collect_in_order over the indices [0, count) in fixed chunks of `chunk` (a chunk a task): visit(i, out) for every
// i, the results in i order, as one loop over i gives them.
template <class T, class Visit>
std::vector<T> collect_in_order_by_index(size_t count, size_t chunk, Visit&& visit) {
  return collect_in_order<T>(int((count + chunk - 1) / chunk), [&](int c, std::vector<T>& out) {
    const size_t end = std::min(count, (size_t(c) + 1) * chunk);
    for (size_t i = size_t(c) * chunk; i < end; ++i) visit(i, out);
  });
}

}  // namespace cpmesh
