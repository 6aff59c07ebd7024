#include "octree/tree_walk.h"

#include <algorithm>

#include "cpmesh/shaders.h"

namespace cpmesh::octree {

namespace {
struct WalkPush {
  uint32_t walkers;
  float theta, skin;
  uint32_t capacity;
};
}  // namespace

TreeWalk::TreeWalk(gpu::Context& ctx, bool exact_sets)
    : exact_(ctx, shaders::tree_walk, {uint32_t(exact_sets)}),
      barnes_hut_(ctx, shaders::tree_walk_bh, {uint32_t(exact_sets)}),
      lists_(ctx, shaders::tree_walk_lists, {uint32_t(exact_sets)}) {}

void TreeWalk::record(gpu::Sequence& seq, const gpu::Buffer<glm::uvec4>& nodes, const NodeMoments& moments,
                      const gpu::Buffer<uint32_t>& order, const gpu::Buffer<glm::vec4>& particles,
                      const gpu::Buffer<glm::uvec4>& masks, const gpu::Buffer<glm::vec4>& result,
                      const gpu::Buffer<uint32_t>& counts, const gpu::Buffer<uint32_t>& visits, uint32_t n,
                      uint32_t walkers, float theta) const {
  if (n > particles.size() || n > masks.size() || n > result.size() || n > counts.size() || n > order.size() ||
      n > visits.size())
    throw gpu::Error("tree walk: n exceeds a buffer");
  walkers = std::min(walkers, n);
  seq.dispatch(theta > 0.0f ? barnes_hut_ : exact_,
               {nodes, moments.lo, moments.hi, moments.com, moments.and_mask, order, particles, masks, result, counts,
                visits},
               WalkPush{walkers, theta, 0.0f, 0}, walkers);
}

void TreeWalk::record_lists(gpu::Sequence& seq, const gpu::Buffer<glm::uvec4>& nodes, const NodeMoments& moments,
                            const gpu::Buffer<uint32_t>& order, const gpu::Buffer<glm::vec4>& particles,
                            const gpu::Buffer<glm::uvec4>& masks, const gpu::Buffer<uint32_t>& lists,
                            const gpu::Buffer<uint32_t>& lengths, const gpu::Buffer<uint32_t>& visits,
                            const gpu::Buffer<uint32_t>& longest, uint32_t n, float skin, uint32_t capacity) const {
  if (n > particles.size() || n > masks.size() || n > lengths.size() || n > order.size() || n > visits.size() ||
      capacity == 0 || uint64_t(n) * capacity > lists.size() || uint64_t(n) * capacity > 0xffffffffull ||
      longest.size() < 1)
    throw gpu::Error("neighbour lists: n or the capacity exceeds a buffer");
  if (!(skin >= 0.0f)) throw gpu::Error("neighbour lists: the skin must be >= 0");
  seq.dispatch(lists_,
               {nodes, moments.lo, moments.hi, moments.com, moments.and_mask, order, particles, masks, lists, lengths,
                visits, longest},
               WalkPush{n, 0.0f, skin, capacity}, n);
}

}  // namespace cpmesh::octree
