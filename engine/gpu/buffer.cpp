#include "gpu/buffer.h"

#include <functional>

#include "gpu/submit.h"

namespace cpmesh::gpu {

namespace {

std::string mib(uint64_t bytes) {
  char s[64];
  std::snprintf(s, sizeof s, "%.1f MiB", double(bytes) / (1024.0 * 1024.0));
  return s;
}

void check_size(const Context& ctx, const std::string& label, uint64_t bytes, MemoryUse use) {
  const auto& d = ctx.info();
  auto fail = [&](const char* limit_name, uint64_t limit) {
    throw Error("buffer '" + label + "' needs " + std::to_string(bytes) + " bytes (" + mib(bytes) + "), more than " +
                limit_name + " = " + std::to_string(limit) + " bytes (" + mib(limit) + ") on " + d.name +
                "; reduce the problem size or pick a device with larger limits (`cpmesh devices`)");
  };
  if ((use == MemoryUse::device || use == MemoryUse::readback) && bytes > d.max_storage_buffer_range)
    fail("maxStorageBufferRange", d.max_storage_buffer_range);
  if (use == MemoryUse::texels && (bytes + 15) / 16 > d.max_texel_buffer_elements)
    fail("maxTexelBufferElements x 16", d.max_texel_buffer_elements * 16);
  if (d.max_memory_allocation_size && bytes > d.max_memory_allocation_size)
    fail("maxMemoryAllocationSize", d.max_memory_allocation_size);
  uint64_t largest_heap = 0;
  for (const auto& h : d.heaps)
    if (h.device_local) largest_heap = std::max(largest_heap, h.size);
  if (largest_heap && bytes > largest_heap) fail("the device-local memory heap size", largest_heap);
}

// The VkBuffer's size for `bytes`: at least 16 (Vulkan forbids empty buffers; an empty Buffer still owns a small one
// so that it can be bound), in whole 16-byte texels so that a texel view covers every byte, unless that would pass
// maxStorageBufferRange (then the last partial texel is not in the view); a texel-only buffer always in whole texels.
uint64_t vk_buffer_size(const Context& ctx, uint64_t bytes, MemoryUse use) {
  const uint64_t whole = (bytes + 15) / 16 * 16;
  return std::max<uint64_t>(use == MemoryUse::texels || whole <= ctx.info().max_storage_buffer_range ? whole : bytes, 16);
}

}  // namespace

const vk::raii::BufferView& detail::BufferStorage::texel_view(bool uint_texels) {
  vk::raii::BufferView& view = uint_texels ? uint_view : float_view;
  if (*view) return view;
  const uint64_t texels = vk_buffer_size(*ctx, bytes, MemoryUse(use)) / 16;
  const uint64_t limit = ctx->info().max_texel_buffer_elements;
  if (texels > limit)
    throw Error("buffer '" + label + "' bound as a texel buffer holds " + std::to_string(texels) +
                " 16-byte texels, more than maxTexelBufferElements = " + std::to_string(limit) + " on " +
                ctx->info().name + "; reduce the problem size or pick a device with larger limits (`cpmesh devices`)");
  guarded("creating the texel view of buffer '" + label + "'", [&] {
    const vk::Format format = uint_texels ? vk::Format::eR32G32B32A32Uint : vk::Format::eR32G32B32A32Sfloat;
    view = vk::raii::BufferView(ctx->device(), vk::BufferViewCreateInfo({}, *buffer, format, 0, texels * 16));
  });
  return view;
}

detail::BufferStorage::~BufferStorage() {
  float_view.clear();  // before the buffer goes back to the pool
  uint_view.clear();
  if (!ctx || !allocated_bytes) return;
  // Back to the context for the next buffer of this size (the GPU is done with it: sequences hold their buffers
  // until their fence has signalled).
  Context::PooledBuffer p;
  p.bytes = bytes;
  p.allocated_bytes = allocated_bytes;
  p.use = use;
  p.mapped = mapped;
  p.buffer = std::move(buffer);
  p.memory = std::move(memory);
  ctx->give_back_buffer(std::move(p));
}

BufferBase::BufferBase(Context& ctx, uint64_t bytes, std::string label, MemoryUse use) {
  check_size(ctx, label, bytes, use);
  auto s = std::make_shared<detail::BufferStorage>();
  s->label = std::move(label);
  s->bytes = bytes;
  s->use = int(use);
  Context::PooledBuffer pooled;
  if (ctx.take_pooled(bytes, int(use), pooled)) {
    s->buffer = std::move(pooled.buffer);
    s->memory = std::move(pooled.memory);
    s->mapped = pooled.mapped;
    s->allocated_bytes = pooled.allocated_bytes;
    s->ctx = &ctx;
    if (ctx.validation_enabled())
      ctx.device().setDebugUtilsObjectNameEXT(vk::DebugUtilsObjectNameInfoEXT(
          vk::ObjectType::eBuffer, uint64_t(static_cast<VkBuffer>(*s->buffer)), s->label.c_str()));
    s_ = std::move(s);
    return;
  }
  guarded("creating buffer '" + s->label + "' of " + std::to_string(bytes) + " bytes", [&] {
    using U = vk::BufferUsageFlagBits;
    const uint64_t alloc_bytes = vk_buffer_size(ctx, bytes, use);
    s->buffer = vk::raii::Buffer(ctx.device(), vk::BufferCreateInfo({}, alloc_bytes,
                                                                    U::eStorageBuffer | U::eUniformTexelBuffer |
                                                                        U::eTransferSrc | U::eTransferDst |
                                                                        U::eIndirectBuffer));
    const auto req = s->buffer.getMemoryRequirements();
    using M = vk::MemoryPropertyFlagBits;
    uint32_t type = 0;
    const bool host_side = use == MemoryUse::readback || use == MemoryUse::staging;
    if (host_side)
      type = ctx.memory_type(req.memoryTypeBits, M::eHostVisible | M::eHostCoherent, M::eHostCached);
    else if (ctx.unified_memory())
      type = ctx.memory_type(req.memoryTypeBits, M::eDeviceLocal, M::eHostVisible | M::eHostCoherent | M::eHostCached);
    else
      type = ctx.memory_type(req.memoryTypeBits, M::eDeviceLocal, {});
    s->memory = vk::raii::DeviceMemory(ctx.device(), vk::MemoryAllocateInfo(req.size, type));
    s->buffer.bindMemory(*s->memory, 0);
    if (ctx.validation_enabled())  // validation messages then name the buffer
      ctx.device().setDebugUtilsObjectNameEXT(vk::DebugUtilsObjectNameInfoEXT(
          vk::ObjectType::eBuffer, uint64_t(static_cast<VkBuffer>(*s->buffer)), s->label.c_str()));
    s->allocated_bytes = req.size;
    s->ctx = &ctx;
    ctx.note_allocation(req.size);
    const auto flags = ctx.physical_device().getMemoryProperties().memoryTypes[type].propertyFlags;
    // Device buffers are mapped only where the host reads them at cache speed (unified memory, above); elsewhere
    // (a device-local type that is host-visible through an uncached BAR) they go through staging.
    const bool map = (flags & M::eHostVisible) && (flags & M::eHostCoherent) &&
                     (host_side || (ctx.unified_memory() && (flags & M::eHostCached)));
    if (map) s->mapped = s->memory.mapMemory(0, VK_WHOLE_SIZE);
  });
  s_ = std::move(s);
}

void BufferBase::upload_bytes(const void* src, uint64_t bytes, uint64_t offset) {
  if (bytes == 0) return;
  if (offset + bytes > s_->bytes)
    throw Error("upload of " + std::to_string(bytes) + " bytes at offset " + std::to_string(offset) +
                " overruns buffer '" + s_->label + "' of " + std::to_string(s_->bytes) + " bytes");
  if (s_->mapped) {
    std::memcpy(static_cast<char*>(s_->mapped) + offset, src, bytes);
    return;
  }
  BufferBase staging(*s_->ctx, bytes, s_->label + " (staging)", MemoryUse::staging);
  std::memcpy(staging.s_->mapped, src, bytes);
  submit_once(*s_->ctx, "uploading to buffer '" + s_->label + "'", [&](const vk::raii::CommandBuffer& cb) {
    cb.copyBuffer(staging.handle(), handle(), vk::BufferCopy(0, offset, bytes));
  });
}

void BufferBase::download_bytes(void* dst, uint64_t bytes, uint64_t offset) const {
  if (bytes == 0) return;
  if (offset + bytes > s_->bytes)
    throw Error("download of " + std::to_string(bytes) + " bytes at offset " + std::to_string(offset) +
                " overruns buffer '" + s_->label + "' of " + std::to_string(s_->bytes) + " bytes");
  if (s_->mapped) {
    std::memcpy(dst, static_cast<const char*>(s_->mapped) + offset, bytes);
    return;
  }
  BufferBase staging(*s_->ctx, bytes, s_->label + " (staging)", MemoryUse::staging);
  submit_once(*s_->ctx, "downloading from buffer '" + s_->label + "'", [&](const vk::raii::CommandBuffer& cb) {
    cb.copyBuffer(handle(), staging.handle(), vk::BufferCopy(offset, 0, bytes));
  });
  std::memcpy(dst, staging.s_->mapped, bytes);
}

}  // namespace cpmesh::gpu
