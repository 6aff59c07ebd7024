#pragma once
// Morton keys of particle positions and their sort (the first steps of the GPU octree, issue 6): keys by
// shaders/morton_codes.comp, then the 64-bit radix sort with the particle indices as payload, so indices[] lists the
// particles in Z-order.
#include <glm/glm.hpp>

#include "primitives/radix_sort.h"

namespace cpmesh::octree {

struct MortonBox {
  glm::vec3 min{0.0f};
  glm::vec3 scale{1.0f};  // 2^21 / extent per axis
  // A box holding [lo, hi] (local coordinates), cubic so that octree cells are cubes.
  static MortonBox around(const glm::vec3& lo, const glm::vec3& hi);
};

class MortonSort {
 public:
  explicit MortonSort(gpu::Context& ctx);
  // keys[i], indices[i] for i < n: sorted Morton keys and the particle each came from (stable for equal keys).
  // levels (1..21): sorted by the top 3 x levels bits only, all an octree of that depth looks at (fewer passes).
  void record(gpu::Sequence& seq, const gpu::Buffer<glm::vec4>& positions, const MortonBox& box,
              const gpu::Buffer<uint64_t>& keys, const gpu::Buffer<uint32_t>& indices, uint32_t n,
              uint32_t levels = 21) const;

 private:
  gpu::Kernel codes_;
  gpu::RadixSort sort_;
};

}  // namespace cpmesh::octree
