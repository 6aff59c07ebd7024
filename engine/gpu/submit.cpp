#include "gpu/submit.h"

namespace cpmesh::gpu {

void full_barrier(const vk::raii::CommandBuffer& cb) {
  using S = vk::PipelineStageFlagBits;
  using A = vk::AccessFlagBits;
  const vk::MemoryBarrier barrier(A::eShaderWrite | A::eTransferWrite,
                                  A::eShaderRead | A::eShaderWrite | A::eTransferRead | A::eTransferWrite |
                                      A::eIndirectCommandRead | A::eHostRead);
  cb.pipelineBarrier(S::eComputeShader | S::eTransfer, S::eComputeShader | S::eTransfer | S::eDrawIndirect | S::eHost,
                     {}, barrier, {}, {});
}

void submit_once(Context& ctx, const std::string& doing,
                 const std::function<void(const vk::raii::CommandBuffer&)>& record) {
  guarded(doing, [&] {
    vk::raii::CommandBuffers cbs(ctx.device(),
                                 vk::CommandBufferAllocateInfo(*ctx.command_pool(), vk::CommandBufferLevel::ePrimary, 1));
    const auto& cb = cbs[0];
    cb.begin(vk::CommandBufferBeginInfo(vk::CommandBufferUsageFlagBits::eOneTimeSubmit));
    record(cb);
    full_barrier(cb);
    cb.end();
    vk::raii::Fence fence(ctx.device(), vk::FenceCreateInfo());
    const vk::CommandBuffer handle = *cb;
    ctx.queue().submit(vk::SubmitInfo({}, {}, handle), *fence);
    while (ctx.device().waitForFences(*fence, VK_TRUE, UINT64_MAX) == vk::Result::eTimeout) {
    }
  });
}

}  // namespace cpmesh::gpu
