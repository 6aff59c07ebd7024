#pragma once
// A Sequence records many dispatches, copies and barriers into one command buffer and submits them at once:
//     gpu::Sequence(ctx).dispatch(morton, {pos, keys}, MortonParams{box, n}, n).barrier().submit_and_wait();
// It holds what it recorded (buffers, pipelines, descriptor sets) until its fence has signalled, so temporaries may go
// out of scope on the host right after recording. A recorded sequence can be submitted again (same push constants).
// Dispatches are sized in threads; the group count is rounded up and spread over y when it exceeds the device's
// maxComputeWorkGroupCount[0] (shaders use flat_group_id() from shaders/shared/common.glsl).
#include <cstring>
#include <initializer_list>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "gpu/buffer.h"
#include "gpu/kernel.h"

namespace cpmesh::gpu {

// A buffer bound to a dispatch (implicitly from any Buffer<T>).
struct Binding {
  Binding(const BufferBase& b) : storage(b.storage()) {}  // NOLINT: implicit by design
  std::shared_ptr<detail::BufferStorage> storage;
};

struct NoPushConstants {};

class Sequence {
 public:
  explicit Sequence(Context& ctx);
  ~Sequence();
  Sequence(const Sequence&) = delete;
  Sequence& operator=(const Sequence&) = delete;

  // Runs `threads` invocations (rounded up to whole workgroups) of `kernel`. PC must match the shader's push-constant
  // block byte for byte (its size is checked against the SPIR-V).
  template <class PC>
  Sequence& dispatch(const Kernel& kernel, std::initializer_list<Binding> buffers, const PC& pc, uint64_t threads) {
    return dispatch_bytes(kernel, buffers, as_bytes(pc), threads);
  }
  Sequence& dispatch(const Kernel& kernel, std::initializer_list<Binding> buffers, uint64_t threads) {
    return dispatch_bytes(kernel, buffers, {}, threads);
  }
  // Group counts read by the GPU from `args` at `offset` (three uint32: x, y, z), written by an earlier dispatch.
  template <class PC>
  Sequence& dispatch_indirect(const Kernel& kernel, std::initializer_list<Binding> buffers, const PC& pc,
                              const BufferBase& args, uint64_t offset = 0) {
    return dispatch_indirect_bytes(kernel, buffers, as_bytes(pc), args, offset);
  }

  Sequence& barrier();  // every earlier write visible to every later command
  Sequence& copy(const BufferBase& src, const BufferBase& dst, uint64_t bytes, uint64_t src_offset = 0,
                 uint64_t dst_offset = 0);
  Sequence& fill(const BufferBase& dst, uint32_t value);  // whole buffer, 32-bit pattern

  void submit();  // ends recording (first time) and submits
  void wait();    // waits for the last submission; feeds timestamps to the context's profile
  void submit_and_wait() {
    submit();
    wait();
  }
  Context& context() const { return *ctx_; }
  uint32_t dispatch_count() const { return uint32_t(timed_.size()); }

 private:
  template <class PC>
  static std::span<const std::byte> as_bytes(const PC& pc) {
    static_assert(std::is_trivially_copyable_v<PC>);
    if constexpr (std::is_same_v<PC, NoPushConstants>) return {};
    return {reinterpret_cast<const std::byte*>(&pc), sizeof(PC)};
  }
  Sequence& dispatch_bytes(const Kernel& kernel, std::initializer_list<Binding> buffers,
                           std::span<const std::byte> pc, uint64_t threads);
  Sequence& dispatch_indirect_bytes(const Kernel& kernel, std::initializer_list<Binding> buffers,
                                    std::span<const std::byte> pc, const BufferBase& args, uint64_t offset);
  void bind(const Kernel& kernel, std::initializer_list<Binding> buffers, std::span<const std::byte> pc);
  void begin_timing(const Kernel& kernel);
  void end_timing();
  const vk::raii::CommandBuffer& recording();

  Context* ctx_;
  bool ended_ = false;
  bool in_flight_ = false;
  std::vector<std::shared_ptr<detail::BufferStorage>> held_buffers_;
  std::vector<std::shared_ptr<Kernel::Pipeline>> held_pipelines_;
  std::vector<std::string> timed_;  // kernel name per timestamp pair
  uint32_t sets_in_pool_ = 0;
  static constexpr uint32_t kSetsPerPool = 64;
  static constexpr uint32_t kTimedPerQueryPool = 256;
  std::vector<vk::raii::DescriptorPool> pools_;  // destroying a pool frees its sets
  std::vector<vk::raii::QueryPool> query_pools_;
  vk::raii::CommandBuffers command_buffers_ = nullptr;
  vk::raii::Fence fence_ = nullptr;
};

}  // namespace cpmesh::gpu
