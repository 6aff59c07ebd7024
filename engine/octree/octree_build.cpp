#include "octree/octree_build.h"

#include <algorithm>
#include <stdexcept>

#include "cpmesh/shaders.h"

namespace cpmesh::octree {

OctreeBuild::OctreeBuild(gpu::Context& ctx)
    : ctx_(&ctx),
      compact_(ctx),
      split_(ctx, shaders::octree_split),
      level_(ctx, shaders::octree_level),
      children_(ctx, shaders::octree_children) {}

void OctreeBuild::record(gpu::Sequence& seq, const gpu::Buffer<uint64_t>& keys, uint32_t n, uint32_t leaf_size,
                         const gpu::Buffer<glm::uvec4>& nodes, const gpu::Buffer<glm::uvec2>& level_info,
                         uint32_t max_level) const {
  if (n > keys.size() || nodes.size() < node_capacity(n, leaf_size) || level_info.size() < 22)
    throw gpu::Error("octree build: buffers too small for " + std::to_string(n) + " particles");
  if (leaf_size == 0) throw gpu::Error("octree build: leaf size must be at least 1");
  if (max_level < 1 || max_level > 21) throw gpu::Error("octree build: max_level must be in 1..21");
  // Root (0, n) and level 0 = (node 0, 1 node); the other levels start empty.
  std::vector<glm::uvec2> info(22, glm::uvec2(0));
  info[0] = glm::uvec2(0, 1);
  seq.copy(gpu::Buffer<glm::uvec2>(*ctx_, info, "octree level info init"), level_info, 22 * sizeof(glm::uvec2))
      .copy(gpu::Buffer<glm::uvec4>(*ctx_, std::vector<glm::uvec4>{glm::uvec4(0, n, 0, 0)}, "octree root"), nodes,
            sizeof(glm::uvec4))
      .barrier();
  gpu::Buffer<uint32_t> flags(*ctx_, n, "octree flags"), starts(*ctx_, n, "octree child starts"),
      counts(*ctx_, 22, "octree level counts");
  for (uint32_t level = 0; level < max_level; ++level) {
    const struct { uint32_t n, level, leaf_size; } split_push{n, level, leaf_size};
    seq.dispatch(split_, {keys, nodes, level_info, flags}, split_push, n).barrier();
    compact_.record_indices(seq, flags, n, starts, counts, level + 1);
    const struct { uint32_t level; } level_push{level};
    seq.barrier().dispatch(level_, {level_info, counts}, level_push, 1).barrier();
    const struct { uint32_t n, level; } children_push{n, level};
    seq.dispatch(children_, {starts, nodes, level_info}, children_push, n).barrier();
  }
}

std::vector<glm::uvec4> particle_masks(const std::vector<uint32_t>& features,
                                       const std::vector<fields::MaterialSet>& feature_masks) {
  std::vector<glm::uvec4> masks(features.size());
  for (size_t i = 0; i < features.size(); ++i) {
    if (features[i] >= feature_masks.size())
      throw std::invalid_argument("particle masks: a feature index out of range");
    const fields::MaterialSet& s = feature_masks[features[i]];
    const uint64_t m = s.mask64(), p = s.packed();
    masks[i] = glm::uvec4(uint32_t(m), uint32_t(m >> 32), uint32_t(p), uint32_t(p >> 32));
  }
  return masks;
}

OctreeMoments::OctreeMoments(gpu::Context& ctx, bool exact_sets)
    : kernel_(ctx, shaders::octree_moments, {uint32_t(exact_sets)}) {}

void OctreeMoments::record(gpu::Sequence& seq, const gpu::Buffer<glm::uvec4>& nodes,
                           const gpu::Buffer<glm::uvec2>& level_info, const gpu::Buffer<uint32_t>& order,
                           const gpu::Buffer<glm::vec4>& particles, const gpu::Buffer<glm::uvec4>& masks,
                           const NodeMoments& moments, uint32_t n, uint32_t max_level) const {
  if (moments.lo.size() < nodes.size()) throw gpu::Error("octree moments: the moment buffers need one entry per node");
  if (n > masks.size() || n > particles.size() || n > order.size())
    throw gpu::Error("octree moments: n exceeds a buffer");
  // A level has at most n nodes (disjoint particle ranges), and the root level one.
  for (int level = int(std::min<uint32_t>(max_level, 21)); level >= 0; --level) {
    const struct { uint32_t level; } push{uint32_t(level)};
    seq.dispatch(kernel_,
                 {nodes, level_info, order, particles, moments.lo, moments.hi, moments.com, moments.and_mask, masks},
                 push,
                 std::max<uint32_t>(n, 1))
        .barrier();
  }
}

}  // namespace cpmesh::octree
