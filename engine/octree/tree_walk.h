#pragma once
// Particle energies and gradients by the exact octree walk (shaders/tree_walk.comp; reference ref::particle_energy).
#include <glm/glm.hpp>

#include "octree/octree_build.h"

namespace cpmesh::octree {

class TreeWalk {
 public:
  explicit TreeWalk(gpu::Context& ctx);
  // result[i] = (dE_i/dp_i, E_i); counts[i] = pairs evaluated, bit 31 set if the per-particle work budget ran out;
  // visits[i] = octree nodes visited.
  // feature_masks: per feature, the set of its materials as a 64-bit mask.
  void record(gpu::Sequence& seq, const gpu::Buffer<glm::uvec4>& nodes, const NodeMoments& moments,
              const gpu::Buffer<uint32_t>& order, const gpu::Buffer<glm::vec4>& particles,
              const gpu::Buffer<uint32_t>& features, const gpu::Buffer<uint64_t>& feature_masks,
              const gpu::Buffer<glm::vec4>& result, const gpu::Buffer<uint32_t>& counts,
              const gpu::Buffer<uint32_t>& visits, uint32_t n,
              uint32_t walkers = ~0u,  // walk only the first `walkers` particles in Morton order
              float theta = 0.0f) const;  // 0: exact; > 0: lump far nodes (size / distance < theta) at their centre

  static constexpr uint32_t kBudgetExceeded = 0x80000000u;

 private:
  gpu::Kernel exact_, barnes_hut_;  // shaders/tree_walk.comp without and with BARNES_HUT
};

}  // namespace cpmesh::octree
