#pragma once
// A kernel is one compute shader with its pipeline. Bindings (storage or texel buffers 0..n-1 in set 0), the push-constant size
// and the workgroup size come from the SPIR-V itself (gpu/reflect.h), so adding a kernel takes a registration in
// shaders/CMakeLists.txt, a push-constant struct and one line here:
//     gpu::Kernel morton(ctx, shaders::morton_codes);
// Specialization constants (constant_id 0, 1, ...) are given as 32-bit values in order. Kernels of the same shader and
// constants share one pipeline, made once per context (Context::cached_pipeline).
#include <memory>
#include <string>
#include <vector>

#include "gpu/context.h"
#include "gpu/reflect.h"

namespace cpmesh::gpu {

// How binding b of a shader is bound: a uniform texel buffer where reflection found a (u)samplerBuffer, else a
// storage buffer. The pipeline layout and Sequence's descriptor writes both ask this.
inline vk::DescriptorType descriptor_type(const ShaderLayout& layout, uint32_t binding) {
  return layout.texel_buffers >> binding & 1 ? vk::DescriptorType::eUniformTexelBuffer
                                             : vk::DescriptorType::eStorageBuffer;
}

class Kernel {
 public:
  Kernel(Context& ctx, const ShaderCode& code, std::vector<uint32_t> spec_constants = {});

  const std::string& name() const { return p_->name; }
  const ShaderLayout& layout() const { return p_->layout; }
  uint32_t workgroup_size() const { return p_->layout.local_size[0] * p_->layout.local_size[1] * p_->layout.local_size[2]; }

  struct Pipeline {
    std::string name;
    ShaderLayout layout;
    vk::raii::DescriptorSetLayout set_layout = nullptr;
    vk::raii::PipelineLayout pipeline_layout = nullptr;
    vk::raii::ShaderModule module = nullptr;
    vk::raii::Pipeline pipeline = nullptr;
  };
  const std::shared_ptr<Pipeline>& pipeline() const { return p_; }

 private:
  std::shared_ptr<Pipeline> p_;
};

}  // namespace cpmesh::gpu
