#pragma once
// The elements (tets or triangles) around each vertex, in ascending element order: a table built in parallel (grouped.h),
// and a copy per vertex whose list changed since (split_slivers replaces tets; new vertices get lists there).
// Used by the interface smoothing and the sliver passes (smooth.cpp, remesh_slivers.cpp), with the tet helpers below.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <unordered_map>
#include <vector>

#include "mesh/grouped.h"

namespace cpmesh::mesh {

template <size_t N>
class ElementsAround {
 public:
  ElementsAround(size_t vertices, const std::vector<std::array<uint32_t, N>>& elements)
      : table_(group_by_key(
            vertices, elements.size(),
            [&](size_t e, auto&& add) {
              for (uint32_t v : elements[e]) add(v);
            })) {}
  std::span<const uint32_t> operator[](uint32_t v) const {
    if (!changed_.empty())
      if (const auto it = changed_.find(v); it != changed_.end()) return it->second;
    if (size_t(v) + 1 >= table_.begin.size()) return {};
    return table_[v];
  }
  void add(uint32_t v, uint32_t e) { own(v).push_back(e); }
  void remove(uint32_t v, uint32_t e) {
    auto& l = own(v);
    l.erase(std::remove(l.begin(), l.end(), e), l.end());
  }

 private:
  std::vector<uint32_t>& own(uint32_t v) {
    auto [it, fresh] = changed_.try_emplace(v);
    if (fresh && size_t(v) + 1 < table_.begin.size()) it->second.assign(table_[v].begin(), table_[v].end());
    return it->second;
  }
  Grouped table_;
  std::unordered_map<uint32_t, std::vector<uint32_t>> changed_;
};

// Whether element e has vertex v.
template <size_t N>
bool has_vertex(const std::array<uint32_t, N>& e, uint32_t v) {
  return std::find(e.begin(), e.end(), v) != e.end();
}

// The first of `triangles` that is triangle f (any vertex order), looked up among those around its first vertex;
// UINT32_MAX where none is.
inline uint32_t find_triangle(const ElementsAround<3>& around, const std::vector<std::array<uint32_t, 3>>& triangles,
                              const std::array<uint32_t, 3>& f) {
  for (uint32_t k : around[f[0]])
    if (has_vertex(triangles[k], f[1]) && has_vertex(triangles[k], f[2])) return k;
  return UINT32_MAX;
}

// Whether triangle f (any vertex order) is one of `triangles`.
inline bool has_triangle(const ElementsAround<3>& around, const std::vector<std::array<uint32_t, 3>>& triangles,
                         const std::array<uint32_t, 3>& f) {
  return find_triangle(around, triangles, f) != UINT32_MAX;
}

// The face of tet t opposite its vertex i (the other three, in order).
inline std::array<uint32_t, 3> face_opposite(const std::array<uint32_t, 4>& t, int i) {
  std::array<uint32_t, 3> f{};
  int n = 0;
  for (int a = 0; a < 4; ++a)
    if (a != i) f[size_t(n++)] = t[size_t(a)];
  return f;
}

// The tet across face i of tet t (found among the tets around the face's first vertex), or UINT32_MAX.
inline uint32_t tet_across(const ElementsAround<4>& around, const std::vector<std::array<uint32_t, 4>>& tets, uint32_t t,
                           int i) {
  const auto f = face_opposite(tets[t], i);
  for (uint32_t u : around[f[0]])
    if (u != t && has_vertex(tets[u], f[1]) && has_vertex(tets[u], f[2])) return u;
  return UINT32_MAX;
}

// Keeps, in order, the tets t for which keep(t) holds (it may read tets[t] and region[t]), with their regions; the
// sliver passes drop replaced tets this way, drop_pockets a piece's pockets. Returns how many are kept.
template <class Keep>
size_t keep_tets(std::vector<std::array<uint32_t, 4>>& tets, std::vector<int>& region, Keep keep) {
  size_t w = 0;
  for (size_t t = 0; t < tets.size(); ++t) {
    if (!keep(t)) continue;
    tets[w] = tets[t];
    region[w] = region[t];
    ++w;
  }
  tets.resize(w);
  region.resize(w);
  return w;
}

}  // namespace cpmesh::mesh
