#include "gpu/sequence.h"

#include <algorithm>
#include <array>

#include "gpu/submit.h"

namespace cpmesh::gpu {

Sequence::Sequence(Context& ctx) : ctx_(&ctx) {
  guarded("creating a command sequence", [&] {
    command_buffers_ = vk::raii::CommandBuffers(
        ctx.device(), vk::CommandBufferAllocateInfo(*ctx.command_pool(), vk::CommandBufferLevel::ePrimary, 1));
    fence_ = vk::raii::Fence(ctx.device(), vk::FenceCreateInfo());
    command_buffers_[0].begin(vk::CommandBufferBeginInfo());
  });
}

Sequence::~Sequence() {
  if (in_flight_) {
    try {
      wait();
    } catch (...) {
      // A destructor cannot report; the device is lost or out of memory and the next call will say so.
    }
  }
}

const vk::raii::CommandBuffer& Sequence::recording() {
  if (ended_) throw Error("a gpu::Sequence cannot record after it was submitted; start a new Sequence");
  return command_buffers_[0];
}

void Sequence::bind(const Kernel& kernel, std::initializer_list<Binding> buffers, std::span<const std::byte> pc) {
  const auto& p = kernel.pipeline();
  const auto& L = p->layout;
  if (buffers.size() != L.bindings)
    throw Error("dispatch of '" + p->name + "' with " + std::to_string(buffers.size()) + " buffers; the shader binds " +
                std::to_string(L.bindings));
  if (pc.size() != L.push_constant_bytes)
    throw Error("dispatch of '" + p->name + "' with " + std::to_string(pc.size()) +
                " bytes of push constants; the shader's block is " + std::to_string(L.push_constant_bytes) + " bytes");
  const auto& cb = recording();
  guarded("recording '" + p->name + "'", [&] {
    if (!buffers.size()) return;
    if (pools_.empty() || sets_in_pool_ == kSetsPerPool) {
      const std::array<vk::DescriptorPoolSize, 2> sizes = {
          vk::DescriptorPoolSize(vk::DescriptorType::eStorageBuffer, kSetsPerPool * 16),
          vk::DescriptorPoolSize(vk::DescriptorType::eUniformTexelBuffer, kSetsPerPool * 16)};
      pools_.emplace_back(ctx_->device(), vk::DescriptorPoolCreateInfo({}, kSetsPerPool, sizes));
      sets_in_pool_ = 0;
    }
    if (L.bindings > 16) throw Error("shader '" + p->name + "' binds more than 16 buffers");
    const vk::DescriptorSetLayout set_layout = *p->set_layout;
    const vk::Device device = *ctx_->device();
    const vk::DescriptorSet set = device.allocateDescriptorSets(vk::DescriptorSetAllocateInfo(*pools_.back(), set_layout))[0];
    ++sets_in_pool_;
    // The writes point into infos and views: both reserved up front, so they never move.
    std::vector<vk::DescriptorBufferInfo> infos;
    std::vector<vk::BufferView> views;
    std::vector<vk::WriteDescriptorSet> writes;
    infos.reserve(buffers.size());
    views.reserve(buffers.size());
    for (const auto& b : buffers) {
      const uint32_t i = uint32_t(writes.size());
      const vk::DescriptorType type = descriptor_type(L, i);
      if (type == vk::DescriptorType::eUniformTexelBuffer)
        writes.emplace_back(set, i, 0, 1, type, nullptr, nullptr,
                            &views.emplace_back(*b.storage->texel_view(L.uint_texels >> i & 1)));
      else if (b.storage->bytes > ctx_->info().max_storage_buffer_range)
        throw Error("buffer '" + b.storage->label + "' of " + std::to_string(b.storage->bytes) +
                    " bytes is bound as a storage buffer, beyond maxStorageBufferRange = " +
                    std::to_string(ctx_->info().max_storage_buffer_range) + " bytes on " + ctx_->info().name +
                    " (a texel buffer may be larger)");
      else
        writes.emplace_back(set, i, 0, 1, type, nullptr, &infos.emplace_back(*b.storage->buffer, 0, VK_WHOLE_SIZE));
      held_buffers_.push_back(b.storage);
    }
    device.updateDescriptorSets(writes, {});
    cb.bindDescriptorSets(vk::PipelineBindPoint::eCompute, *p->pipeline_layout, 0, set, {});
  });
  cb.bindPipeline(vk::PipelineBindPoint::eCompute, *p->pipeline);
  if (!pc.empty())
    cb.pushConstants<std::byte>(*p->pipeline_layout, vk::ShaderStageFlagBits::eCompute, 0, pc);
  held_pipelines_.push_back(p);
}

void Sequence::begin_timing(const Kernel& kernel) {
  if (!ctx_->profiling()) return;
  const uint32_t k = uint32_t(timed_.size());
  const auto& cb = recording();
  if (k % kTimedPerQueryPool == 0) {
    query_pools_.emplace_back(ctx_->device(),
                              vk::QueryPoolCreateInfo({}, vk::QueryType::eTimestamp, 2 * kTimedPerQueryPool));
    cb.resetQueryPool(*query_pools_.back(), 0, 2 * kTimedPerQueryPool);
  }
  cb.writeTimestamp(vk::PipelineStageFlagBits::eTopOfPipe, *query_pools_.back(), 2 * (k % kTimedPerQueryPool));
  timed_.push_back(kernel.name());
}

void Sequence::end_timing() {
  if (!ctx_->profiling()) return;
  const uint32_t k = uint32_t(timed_.size()) - 1;
  recording().writeTimestamp(vk::PipelineStageFlagBits::eBottomOfPipe, *query_pools_.back(),
                             2 * (k % kTimedPerQueryPool) + 1);
}

Sequence& Sequence::dispatch_bytes(const Kernel& kernel, std::initializer_list<Binding> buffers,
                                   std::span<const std::byte> pc, uint64_t threads) {
  bind(kernel, buffers, pc);
  const uint64_t groups = (threads + kernel.workgroup_size() - 1) / kernel.workgroup_size();
  if (groups == 0) return *this;
  const uint64_t max_x = ctx_->info().max_workgroup_count[0];
  const uint64_t gx = std::min(groups, max_x), gy = (groups + gx - 1) / gx;
  if (gy > ctx_->info().max_workgroup_count[1])
    throw Error("dispatch of '" + kernel.name() + "' over " + std::to_string(threads) +
                " threads exceeds the device's workgroup count limits");
  begin_timing(kernel);
  recording().dispatch(uint32_t(gx), uint32_t(gy), 1);
  end_timing();
  return *this;
}

Sequence& Sequence::dispatch_indirect_bytes(const Kernel& kernel, std::initializer_list<Binding> buffers,
                                            std::span<const std::byte> pc, const BufferBase& args, uint64_t offset) {
  bind(kernel, buffers, pc);
  held_buffers_.push_back(args.storage());
  begin_timing(kernel);
  recording().dispatchIndirect(args.handle(), offset);
  end_timing();
  return *this;
}

Sequence& Sequence::barrier() {
  full_barrier(recording());
  return *this;
}

Sequence& Sequence::copy(const BufferBase& src, const BufferBase& dst, uint64_t bytes, uint64_t src_offset,
                         uint64_t dst_offset) {
  if (src_offset + bytes > src.bytes() || dst_offset + bytes > dst.bytes())
    throw Error("copy of " + std::to_string(bytes) + " bytes from '" + src.label() + "' to '" + dst.label() +
                "' overruns a buffer");
  if (bytes == 0) return *this;
  recording().copyBuffer(src.handle(), dst.handle(), vk::BufferCopy(src_offset, dst_offset, bytes));
  held_buffers_.push_back(src.storage());
  held_buffers_.push_back(dst.storage());
  return *this;
}

Sequence& Sequence::fill(const BufferBase& dst, uint32_t value) {
  recording().fillBuffer(dst.handle(), 0, VK_WHOLE_SIZE, value);
  held_buffers_.push_back(dst.storage());
  return *this;
}

void Sequence::submit() {
  if (in_flight_) wait();
  guarded("submitting GPU work", [&] {
    if (!ended_) {
      full_barrier(command_buffers_[0]);  // makes results visible to the host after the fence
      command_buffers_[0].end();
      ended_ = true;
    }
    ctx_->device().resetFences(*fence_);
    const vk::CommandBuffer cb = *command_buffers_[0];
    ctx_->queue().submit(vk::SubmitInfo({}, {}, cb), *fence_);
    in_flight_ = true;
  });
}

void Sequence::wait() {
  if (!in_flight_) return;
  guarded("waiting for GPU work", [&] {
    while (ctx_->device().waitForFences(*fence_, VK_TRUE, UINT64_MAX) == vk::Result::eTimeout) {
    }
  });
  in_flight_ = false;
  if (timed_.empty()) return;
  const uint64_t mask = ctx_->timestamp_valid_bits() >= 64 ? ~0ull : (1ull << ctx_->timestamp_valid_bits()) - 1;
  const double period = ctx_->info().timestamp_period_ns;
  for (size_t pool = 0; pool < query_pools_.size(); ++pool) {
    const uint32_t first = uint32_t(pool * kTimedPerQueryPool);
    const uint32_t count = std::min<uint32_t>(kTimedPerQueryPool, uint32_t(timed_.size()) - first);
    const auto [result, stamps] = query_pools_[pool].getResults<uint64_t>(
        0, 2 * count, 2 * count * sizeof(uint64_t), sizeof(uint64_t),
        vk::QueryResultFlagBits::e64 | vk::QueryResultFlagBits::eWait);
    if (result != vk::Result::eSuccess) continue;
    for (uint32_t i = 0; i < count; ++i) {
      const uint64_t t0 = stamps[2 * i] & mask, t1 = stamps[2 * i + 1] & mask;
      ctx_->add_profile_sample(timed_[first + i], double((t1 - t0) & mask) * period * 1e-6);
    }
  }
}

}  // namespace cpmesh::gpu
