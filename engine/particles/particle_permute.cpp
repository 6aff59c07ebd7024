#include "particles/particle_permute.h"

#include "cpmesh/shaders.h"

namespace cpmesh::particles {

ParticlePermute::ParticlePermute(gpu::Context& ctx) : kernel_(ctx, shaders::particle_permute) {}

void ParticlePermute::record(gpu::Sequence& seq, const gpu::Buffer<uint32_t>& order,
                             const gpu::Buffer<glm::vec4>& particles_in, const gpu::Buffer<uint32_t>& features_in,
                             const gpu::Buffer<uint32_t>& ids_in, const gpu::Buffer<glm::uvec4>& masks_in,
                             const gpu::Buffer<glm::vec4>& particles_out, const gpu::Buffer<uint32_t>& features_out,
                             const gpu::Buffer<uint32_t>& ids_out, const gpu::Buffer<glm::uvec4>& masks_out,
                             uint32_t n) const {
  for (size_t size : {order.size(), particles_in.size(), features_in.size(), ids_in.size(), masks_in.size(),
                      particles_out.size(), features_out.size(), ids_out.size(), masks_out.size()})
    if (n > size) throw gpu::Error("particle permute: n exceeds a buffer");
  if (n == 0) return;
  const struct {
    uint32_t n;
  } push{n};
  seq.dispatch(kernel_,
               {order, particles_in, features_in, ids_in, masks_in, particles_out, features_out, ids_out, masks_out},
               push, n);
}

}  // namespace cpmesh::particles
