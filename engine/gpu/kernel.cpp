#include "gpu/kernel.h"

namespace cpmesh::gpu {

Kernel::Kernel(Context& ctx, const ShaderCode& code, std::vector<uint32_t> spec_constants) {
  const ShaderLayout L = reflect(code);
  const uint32_t invocations = L.local_size[0] * L.local_size[1] * L.local_size[2];
  if (invocations > ctx.info().max_workgroup_invocations)
    throw Error("shader '" + std::string(code.name) + "' needs " + std::to_string(invocations) +
                " invocations per workgroup; " + ctx.info().name + " allows " +
                std::to_string(ctx.info().max_workgroup_invocations));
  if (spec_constants.size() != L.spec_constants)
    throw Error("shader '" + std::string(code.name) + "' has " + std::to_string(L.spec_constants) +
                " specialization constants; " + std::to_string(spec_constants.size()) + " were given");
  p_ = std::static_pointer_cast<Pipeline>(ctx.cached_pipeline(code.words, spec_constants, [&] {
    auto p = std::make_shared<Pipeline>();
    p->name = code.name;
    p->layout = L;
    guarded("creating the pipeline of shader '" + p->name + "'", [&] {
      std::vector<vk::DescriptorSetLayoutBinding> bindings;
      for (uint32_t b = 0; b < L.bindings; ++b)
        bindings.emplace_back(b, descriptor_type(L, b), 1, vk::ShaderStageFlagBits::eCompute);
      p->set_layout = vk::raii::DescriptorSetLayout(ctx.device(), vk::DescriptorSetLayoutCreateInfo({}, bindings));
      const vk::PushConstantRange range(vk::ShaderStageFlagBits::eCompute, 0, L.push_constant_bytes);
      const vk::DescriptorSetLayout set_layout = *p->set_layout;
      vk::PipelineLayoutCreateInfo layout_info({}, set_layout);
      if (L.push_constant_bytes) layout_info.setPushConstantRanges(range);
      p->pipeline_layout = vk::raii::PipelineLayout(ctx.device(), layout_info);
      p->module = vk::raii::ShaderModule(
          ctx.device(), vk::ShaderModuleCreateInfo({}, code.word_count * sizeof(uint32_t), code.words));
      std::vector<vk::SpecializationMapEntry> entries;
      for (uint32_t i = 0; i < spec_constants.size(); ++i)
        entries.emplace_back(i, uint32_t(i * sizeof(uint32_t)), sizeof(uint32_t));
      const vk::SpecializationInfo spec(entries, vk::ArrayProxyNoTemporaries<const uint32_t>(spec_constants));
      const vk::PipelineShaderStageCreateInfo stage({}, vk::ShaderStageFlagBits::eCompute, *p->module, "main",
                                                    spec_constants.empty() ? nullptr : &spec);
      p->pipeline = vk::raii::Pipeline(ctx.device(), nullptr,
                                       vk::ComputePipelineCreateInfo({}, stage, *p->pipeline_layout));
      if (ctx.validation_enabled())
        ctx.device().setDebugUtilsObjectNameEXT(vk::DebugUtilsObjectNameInfoEXT(
            vk::ObjectType::ePipeline, uint64_t(static_cast<VkPipeline>(*p->pipeline)), p->name.c_str()));
    });
    return std::shared_ptr<void>(p);
  }));
}

}  // namespace cpmesh::gpu
