#pragma once
// Particle energies and gradients by the exact octree walk (shaders/tree_walk.comp; reference ref::particle_energy),
// and the same walk building Verlet neighbour lists (reference ref::neighbour_lists).
#include <glm/glm.hpp>

#include "octree/octree_build.h"

namespace cpmesh::octree {

class TreeWalk {
 public:
  // exact_sets (fields::needs_exact_sets of the particles' sets): the interaction rule compares the material slots
  // after the masks; it must match the OctreeMoments that made the moments.
  explicit TreeWalk(gpu::Context& ctx, bool exact_sets = false);
  // result[i] = (dE_i/dp_i, E_i); counts[i] = pairs evaluated, bit 31 set if the per-particle work budget ran out;
  // visits[i] = octree nodes visited.
  // masks: per particle, its feature's set of materials (particle_masks).
  void record(gpu::Sequence& seq, const gpu::Buffer<glm::uvec4>& nodes, const NodeMoments& moments,
              const gpu::Buffer<uint32_t>& order, const gpu::Buffer<glm::vec4>& particles,
              const gpu::Buffer<glm::uvec4>& masks, const gpu::Buffer<glm::vec4>& result,
              const gpu::Buffer<uint32_t>& counts, const gpu::Buffer<uint32_t>& visits, uint32_t n,
              uint32_t walkers = ~0u,  // walk only the first `walkers` particles in Morton order
              float theta = 0.0f) const;  // 0: exact; > 0: lump far nodes (size / distance < theta) at their centre

  // Verlet neighbour lists (shaders/tree_walk.comp with NEIGHBOUR_LIST): for each particle i, the particles j that
  // interact with i by the feature rule and lie within SUPPORT min(h_i, h_j) (1 + skin), SUPPORT = 2 cos(pi/6) (the
  // pair's support widened by the skin), in walk order:
  // lists[i * capacity + q] for q < min(lengths[i], capacity); lengths[i] = the full count (bit 31 as counts above);
  // longest[0] = max(longest[0], every full count) (the caller zeroes it, and grows the capacity when it exceeds it).
  void record_lists(gpu::Sequence& seq, const gpu::Buffer<glm::uvec4>& nodes, const NodeMoments& moments,
                    const gpu::Buffer<uint32_t>& order, const gpu::Buffer<glm::vec4>& particles,
                    const gpu::Buffer<glm::uvec4>& masks, const gpu::Buffer<uint32_t>& lists,
                    const gpu::Buffer<uint32_t>& lengths, const gpu::Buffer<uint32_t>& visits,
                    const gpu::Buffer<uint32_t>& longest, uint32_t n, float skin, uint32_t capacity) const;

  static constexpr uint32_t kBudgetExceeded = 0x80000000u;

 private:
  gpu::Kernel exact_, barnes_hut_, lists_;  // shaders/tree_walk.comp plain, with BARNES_HUT, with NEIGHBOUR_LIST
};

}  // namespace cpmesh::octree
