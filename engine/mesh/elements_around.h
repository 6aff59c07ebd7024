#pragma once
// The elements (tets or triangles) around each vertex, in ascending element order: a CSR table built in parallel,
// and a copy per vertex whose list changed since (split_slivers replaces tets; new vertices get lists there).
// Used by the interface smoothing and the sliver passes (smooth.cpp).
#include <algorithm>
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <span>
#include <unordered_map>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace cpmesh::mesh {

template <size_t N>
class ElementsAround {
 public:
  ElementsAround(size_t vertices, const std::vector<std::array<uint32_t, N>>& elements) : begin_(vertices + 1, 0) {
    std::vector<std::atomic<size_t>> count(vertices);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, elements.size()), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t e = r.begin(); e != r.end(); ++e)
        for (uint32_t v : elements[e]) count[v].fetch_add(1, std::memory_order_relaxed);
    });
    for (size_t v = 0; v < vertices; ++v) begin_[v + 1] = begin_[v] + count[v].load(std::memory_order_relaxed);
    for (size_t v = 0; v < vertices; ++v) count[v].store(begin_[v], std::memory_order_relaxed);
    list_.resize(begin_[vertices]);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, elements.size()), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t e = r.begin(); e != r.end(); ++e)
        for (uint32_t v : elements[e]) list_[count[v].fetch_add(1, std::memory_order_relaxed)] = uint32_t(e);
    });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, vertices), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t v = r.begin(); v != r.end(); ++v) std::sort(list_.begin() + begin_[v], list_.begin() + begin_[v + 1]);
    });
  }
  std::span<const uint32_t> operator[](uint32_t v) const {
    if (!changed_.empty())
      if (const auto it = changed_.find(v); it != changed_.end()) return it->second;
    if (size_t(v) + 1 >= begin_.size()) return {};
    return {list_.data() + begin_[v], list_.data() + begin_[v + 1]};
  }
  void add(uint32_t v, uint32_t e) { own(v).push_back(e); }
  void remove(uint32_t v, uint32_t e) {
    auto& l = own(v);
    l.erase(std::remove(l.begin(), l.end(), e), l.end());
  }

 private:
  std::vector<uint32_t>& own(uint32_t v) {
    auto [it, fresh] = changed_.try_emplace(v);
    if (fresh && size_t(v) + 1 < begin_.size()) it->second.assign(list_.begin() + begin_[v], list_.begin() + begin_[v + 1]);
    return it->second;
  }
  std::vector<size_t> begin_;
  std::vector<uint32_t> list_;
  std::unordered_map<uint32_t, std::vector<uint32_t>> changed_;
};

}  // namespace cpmesh::mesh
