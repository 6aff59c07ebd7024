#pragma once
// A triangle's three vertex indices in ascending order: the key under which the two tets sharing a face (or a tet
// face and an interface triangle) meet, whatever order each lists them in. Used by the tet adjacency (extract.cpp),
// the sliver pass (smooth.cpp) and the conformity check (quality.cpp nonconforming_faces). And a material pair's key,
// whatever order it is given in: the interface an edge or a triangle belongs to (quality.cpp, refine.cpp,
// mend_topology.cpp).
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>

namespace cpmesh::mesh {

struct FaceKey {
  std::array<uint32_t, 3> v;
  explicit FaceKey(std::array<uint32_t, 3> f) : v(f) { std::sort(v.begin(), v.end()); }
  bool operator==(const FaceKey& o) const { return v == o.v; }
  bool operator<(const FaceKey& o) const { return v < o.v; }
};

struct FaceKeyHash {
  size_t operator()(const FaceKey& k) const {
    uint64_t h = uint64_t(k.v[0]) * 0x9E3779B97F4A7C15ull;
    h ^= (uint64_t(k.v[1]) + 0x7F4A7C15ull) * 0xC2B2AE3D27D4EB4Full;
    h ^= (uint64_t(k.v[2]) + 0x165667B1ull) * 0xD6E8FEB86659FD93ull;
    return size_t(h ^ (h >> 29));
  }
};

// The smaller material in the high 16 bits, the larger in the low.
inline uint32_t pair_key(uint16_t a, uint16_t b) { return uint32_t(std::min(a, b)) << 16 | std::max(a, b); }

}  // namespace cpmesh::mesh
