#include "octree/morton.h"

#include <algorithm>

#include "cpmesh/shaders.h"

namespace cpmesh::octree {

MortonBox MortonBox::around(const glm::vec3& lo, const glm::vec3& hi) {
  const glm::vec3 extent = hi - lo;
  const float side = std::max({extent.x, extent.y, extent.z, 1e-6f}) * 1.0001f;  // the top face maps inside
  MortonBox b;
  b.min = lo;
  b.scale = glm::vec3(2097152.0f / side);
  return b;
}

MortonSort::MortonSort(gpu::Context& ctx) : codes_(ctx, shaders::morton_codes), sort_(ctx) {}

void MortonSort::record(gpu::Sequence& seq, const gpu::Buffer<glm::vec4>& positions, const MortonBox& box,
                        const gpu::Buffer<uint64_t>& keys, const gpu::Buffer<uint32_t>& indices, uint32_t n,
                        uint32_t levels) const {
  if (n > positions.size() || n > keys.size() || n > indices.size()) throw gpu::Error("morton sort: n exceeds a buffer");
  const struct {
    glm::vec4 box_min, scale;
    uint32_t n;
  } push{glm::vec4(box.min, 0.0f), glm::vec4(box.scale, 0.0f), n};
  seq.dispatch(codes_, {positions, keys, indices}, push, n).barrier();
  if (levels < 1 || levels > 21) throw gpu::Error("morton sort: levels must be in 1..21");
  sort_.record(seq, keys, indices, n, 3 * levels, 63 - 3 * levels);
  seq.barrier();
}

}  // namespace cpmesh::octree
