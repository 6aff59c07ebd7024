#pragma once
// Device buffers owned by RAII objects. A buffer's storage is shared with every Sequence that records it, so it lives
// until the GPU is done with it even if the Buffer object goes away first.
//
// Memory: on unified-memory devices (lavapipe, integrated GPUs: device-local memory the host reads through its
// cache) buffers live in device-local, host-visible memory and are mapped; elsewhere (discrete GPUs, a resizable BAR
// included) they live in device-local memory and upload/download go through a temporary staging buffer in cached
// host memory. Either way upload()/download() work and block until done.
#include <cstring>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "gpu/context.h"

namespace cpmesh::gpu {

namespace detail {
struct BufferStorage {
  Context* ctx = nullptr;
  std::string label;
  uint64_t bytes = 0;            // as asked for (may be 0)
  uint64_t allocated_bytes = 0;  // what the allocation really takes
  void* mapped = nullptr;        // non-null when host-visible
  int use = 0;                   // MemoryUse, for recycling
  vk::raii::Buffer buffer = nullptr;
  vk::raii::DeviceMemory memory = nullptr;
  // The buffer seen as a uniform texel buffer of RGBA32F texels (a shader's samplerBuffer) or RGBA32UI texels
  // (usamplerBuffer), each made at its first such binding: lavapipe gathers texels for all lanes at once but loads
  // storage buffers lane by lane and component by component, so read-only vec4 data that many lanes fetch at
  // scattered places reads faster this way.
  vk::raii::BufferView float_view = nullptr, uint_view = nullptr;
  const vk::raii::BufferView& texel_view(bool uint_texels);
  ~BufferStorage();
};
}  // namespace detail

enum class MemoryUse {
  device,    // device-local; host access through staging unless the device has unified memory
  readback,  // host-visible and cached: for small results the host reads every iteration
  texels,    // as device, bound only as a texel buffer: up to maxTexelBufferElements 16-byte texels rather than
             // maxStorageBufferRange bytes (Sequence refuses to bind a buffer beyond that range as a storage buffer)
  staging,   // as readback, never bound: the host side of an upload or a download
};

class BufferBase {
 public:
  BufferBase() = default;
  BufferBase(Context& ctx, uint64_t bytes, std::string label, MemoryUse use = MemoryUse::device);

  bool valid() const { return bool(s_); }
  uint64_t bytes() const { return s_ ? s_->bytes : 0; }
  const std::string& label() const { return s_->label; }
  vk::Buffer handle() const { return *s_->buffer; }
  Context& context() const { return *s_->ctx; }
  const std::shared_ptr<detail::BufferStorage>& storage() const { return s_; }

  // Blocking host <-> device copies of a byte range. The GPU must not be using the range (wait for sequences first).
  void upload_bytes(const void* src, uint64_t bytes, uint64_t offset = 0);
  void download_bytes(void* dst, uint64_t bytes, uint64_t offset = 0) const;

 protected:
  std::shared_ptr<detail::BufferStorage> s_;
};

template <class T>
class Buffer : public BufferBase {
  static_assert(std::is_trivially_copyable_v<T>, "device buffers hold trivially copyable types");

 public:
  Buffer() = default;
  Buffer(Context& ctx, size_t count, std::string label = "buffer", MemoryUse use = MemoryUse::device)
      : BufferBase(ctx, uint64_t(count) * sizeof(T), std::move(label), use), count_(count) {}
  Buffer(Context& ctx, std::span<const T> data, std::string label = "buffer", MemoryUse use = MemoryUse::device)
      : Buffer(ctx, data.size(), std::move(label), use) {
    upload(data);
  }
  Buffer(Context& ctx, const std::vector<T>& data, std::string label = "buffer", MemoryUse use = MemoryUse::device)
      : Buffer(ctx, std::span<const T>(data), std::move(label), use) {}

  size_t size() const { return count_; }

  void upload(std::span<const T> data, size_t first = 0) {
    check_range(first, data.size(), "upload to");
    upload_bytes(data.data(), data.size_bytes(), first * sizeof(T));
  }
  std::vector<T> download(size_t first = 0, size_t count = size_t(-1)) const {
    if (count == size_t(-1)) count = first <= count_ ? count_ - first : 0;
    check_range(first, count, "download from");
    std::vector<T> out(count);
    download_bytes(out.data(), count * sizeof(T), first * sizeof(T));
    return out;
  }
  T read(size_t i) const { return download(i, 1)[0]; }

 private:
  void check_range(size_t first, size_t count, const char* what) const {
    if (first > count_ || count > count_ - first)
      throw Error(std::string(what) + " buffer '" + label() + "': elements [" + std::to_string(first) + ", " +
                  std::to_string(first + count) + ") are outside its " + std::to_string(count_) + " elements");
  }
  size_t count_ = 0;
};

}  // namespace cpmesh::gpu
