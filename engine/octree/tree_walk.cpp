#include "octree/tree_walk.h"

#include <algorithm>

#include "cpmesh/shaders.h"

namespace cpmesh::octree {

TreeWalk::TreeWalk(gpu::Context& ctx) : exact_(ctx, shaders::tree_walk), barnes_hut_(ctx, shaders::tree_walk_bh) {}

void TreeWalk::record(gpu::Sequence& seq, const gpu::Buffer<glm::uvec4>& nodes, const NodeMoments& moments,
                      const gpu::Buffer<uint32_t>& order, const gpu::Buffer<glm::vec4>& particles,
                      const gpu::Buffer<uint32_t>& features, const gpu::Buffer<uint64_t>& feature_masks,
                      const gpu::Buffer<glm::vec4>& result, const gpu::Buffer<uint32_t>& counts,
                      const gpu::Buffer<uint32_t>& visits, uint32_t n,
                      uint32_t walkers, float theta) const {
  if (n > particles.size() || n > features.size() || n > result.size() || n > counts.size() || n > order.size() ||
      n > visits.size())
    throw gpu::Error("tree walk: n exceeds a buffer");
  walkers = std::min(walkers, n);
  const struct {
    uint32_t walkers;
    float theta;
  } push{walkers, theta};
  seq.dispatch(theta > 0.0f ? barnes_hut_ : exact_,
               {nodes, moments.lo, moments.hi, moments.com, moments.and_mask, order, particles, features,
                feature_masks, result, counts, visits},
               push, walkers);
}

}  // namespace cpmesh::octree
