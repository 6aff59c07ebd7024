#pragma once
// Particles into Morton order on the GPU (shaders/particle_permute.comp; reference ref::particle_permute): after
// MortonSort, slot q takes particle order[q] (position, feature, id and material mask) and order becomes the
// identity. ParticleSystem does this at every octree rebuild, so the walk, the moments and the advection read and
// write neighbours in neighbouring slots; the ids say where each slot's particle came from.
#include <glm/glm.hpp>

#include "gpu/sequence.h"

namespace cpmesh::particles {

class ParticlePermute {
 public:
  explicit ParticlePermute(gpu::Context& ctx);
  void record(gpu::Sequence& seq, const gpu::Buffer<uint32_t>& order, const gpu::Buffer<glm::vec4>& particles_in,
              const gpu::Buffer<uint32_t>& features_in, const gpu::Buffer<uint32_t>& ids_in,
              const gpu::Buffer<glm::uvec4>& masks_in, const gpu::Buffer<glm::vec4>& particles_out,
              const gpu::Buffer<uint32_t>& features_out, const gpu::Buffer<uint32_t>& ids_out,
              const gpu::Buffer<glm::uvec4>& masks_out, uint32_t n) const;

 private:
  gpu::Kernel kernel_;
};

}  // namespace cpmesh::particles
