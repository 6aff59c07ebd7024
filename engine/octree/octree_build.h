#pragma once
// The octree over Morton-sorted particles on the GPU, level by level as in Bonsai (Bedorf et al.): per level, flag
// where the next level's prefix changes inside internal nodes (octree_split), compact those starts, record the level
// (octree_level) and make the child nodes with their parents' links (octree_children). Every dispatch is sized to n
// and reads the counts from GPU buffers, so a build needs no host readback. Reference: ref::build_octree.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "fields/material_set.h"
#include "primitives/compact.h"

namespace cpmesh::octree {

class OctreeBuild {
 public:
  explicit OctreeBuild(gpu::Context& ctx);
  // Node capacity sufficient for n particles: leaves are at most n, internal nodes at most n / (leaf_size + 1) per
  // level.
  static size_t node_capacity(uint32_t n, uint32_t leaf_size) { return n + 21 * (size_t(n) / (leaf_size + 1) + 1) + 1; }
  // nodes: node_capacity() entries, uvec4 (start, count, first_child, level << 8 | child_count);
  // level_info: 22 entries (first node, node count) per level. max_level (1..21): nodes of that level are leaves
  // whatever their count, and the build records only max_level levels (5 dispatches each): a caller that knows how
  // close its particles can be stops at cells a fraction of that size instead of at the keys' 21 bits.
  void record(gpu::Sequence& seq, const gpu::Buffer<uint64_t>& sorted_keys, uint32_t n, uint32_t leaf_size,
              const gpu::Buffer<glm::uvec4>& nodes, const gpu::Buffer<glm::uvec2>& level_info,
              uint32_t max_level = 21) const;

 private:
  gpu::Context* ctx_;
  gpu::Compact compact_;
  gpu::Kernel split_, level_, children_;
};

// Per-node moments, one buffer per quantity so that each stays within maxStorageBufferRange for a million particles:
// lo (box min, min h), hi (box max, 0), com (centre of mass, count), and_mask (AND of the particles' feature masks as
// two float-bit words).
struct NodeMoments {
  NodeMoments(gpu::Context& ctx, size_t nodes)
      : lo(ctx, nodes, "node box min"), hi(ctx, nodes, "node box max"), com(ctx, nodes, "node centre of mass"),
        and_mask(ctx, nodes, "node feature mask") {}
  gpu::Buffer<glm::vec4> lo, hi, com, and_mask;
};

// Per particle, its feature's material set (feature_masks[features[i]]): its mask64 in x (low word) and y, its slots
// in z (0, 1) and w (2, 3): what the moments and the walks (tree_walk.h) read of a particle's feature, one texel each.
// Throws for a feature index outside feature_masks.
std::vector<glm::uvec4> particle_masks(const std::vector<uint32_t>& features,
                                       const std::vector<fields::MaterialSet>& feature_masks);

// Node moments for the tree walk (issue 6): box, smallest sizing h, centre of mass and count per node, bottom-up
// one level per dispatch (shaders/octree_moments.comp; reference ref::octree_moments).
class OctreeMoments {
 public:
  // exact_sets (fields::needs_exact_sets of the particles' sets): the intersections of the slots too, not only of
  // the masks.
  explicit OctreeMoments(gpu::Context& ctx, bool exact_sets = false);
  // order: Morton order -> particle index (MortonSort's indices); particles: xyz position, w sizing h;
  // masks: each particle's feature's material set (particle_masks).
  void record(gpu::Sequence& seq, const gpu::Buffer<glm::uvec4>& nodes, const gpu::Buffer<glm::uvec2>& level_info,
              const gpu::Buffer<uint32_t>& order, const gpu::Buffer<glm::vec4>& particles,
              const gpu::Buffer<glm::uvec4>& masks, const NodeMoments& moments, uint32_t n,
              uint32_t max_level = 21) const;

 private:
  gpu::Kernel kernel_;
};

}  // namespace cpmesh::octree
