#pragma once
// The GPU context: one Vulkan instance, one device, one compute queue. Headless (no surface, no window system).
//
// Device choice: discrete GPU, then integrated, then virtual, then CPU (lavapipe); only devices with Vulkan 1.2 and a
// compute queue qualify. ContextOptions::device (CLI --device) or the environment variable CPMESH_DEVICE overrides the
// choice with an index from `cpmesh devices` or a case-insensitive substring of the device name.
// Not thread-safe: one thread records and submits.
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "gpu/vk.h"

namespace cpmesh::gpu {

struct MemoryHeapInfo {
  uint64_t size = 0;
  bool device_local = false;
};

struct DeviceInfo {
  uint32_t index = 0;
  std::string name;
  std::string type;  // "discrete", "integrated", "virtual", "cpu", "other"
  std::string driver;
  uint32_t api_version = 0;
  bool usable = false;          // Vulkan >= 1.2 with a compute queue
  std::string unusable_reason;  // why not, when !usable
  uint64_t max_storage_buffer_range = 0;
  uint64_t max_texel_buffer_elements = 0;
  uint64_t max_memory_allocation_size = 0;
  uint32_t max_shared_memory = 0;
  uint32_t max_workgroup_invocations = 0;
  uint32_t max_workgroup_count[3] = {0, 0, 0};
  uint32_t subgroup_size = 0;
  bool shader_int64 = false;
  bool shader_float64 = false;
  bool float_atomic_add_buffer = false;  // VK_EXT_shader_atomic_float: float32 atomicAdd on storage buffers
  bool float_atomic_add_shared = false;  // ... and on shared memory
  bool timestamps = false;               // compute queue supports timestamp queries
  double timestamp_period_ns = 0.0;
  std::vector<MemoryHeapInfo> heaps;
};

std::string format_version(uint32_t api_version);

// Every physical device the loader reports, in loader order, with `usable` set. Creates a temporary instance.
std::vector<DeviceInfo> list_devices();

// The device index a Context would choose: `selector` (an index or a case-insensitive name substring; `source` names
// where it came from, for messages) or, when empty, the best usable device by type. Throws gpu::Error when none fits.
uint32_t select_device(const std::vector<DeviceInfo>& devices, const std::string& selector,
                       const std::string& source = "--device");
// The device a Context made with ContextOptions::device = `option` uses: the option, else CPMESH_DEVICE, else the
// automatic choice (select_device).
uint32_t choose_device(const std::vector<DeviceInfo>& devices, const std::string& option);

struct ContextOptions {
  std::string device;       // "" = CPMESH_DEVICE or automatic; else an index or a name substring
  bool validation = false;  // enable VK_LAYER_KHRONOS_validation (also CPMESH_VALIDATION=1); errors are counted
  bool profile = false;     // timestamp every dispatch (where the device supports it) into Context::profile()
  uint32_t max_workgroups_x = 0;  // 0 = the device's limit; tests lower it to exercise the 2-D dispatch split cheaply
  bool force_staging = false;     // never map device buffers: upload/download through staging copies, as on a
                                  // discrete GPU without resizable BAR (tests use it to cover that path on lavapipe)
};

// Per-kernel time from timestamp queries, accumulated over every submission.
struct ProfileEntry {
  uint64_t dispatches = 0;
  double total_ms = 0.0;
};

struct MemoryStats {
  uint64_t current_bytes = 0;
  uint64_t peak_bytes = 0;
  uint64_t allocations = 0;
};

class Context {
 public:
  explicit Context(const ContextOptions& options = {});
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  const DeviceInfo& info() const { return info_; }
  bool validation_enabled() const { return validation_enabled_; }
  bool profiling() const { return profiling_; }

  // Validation messages of error severity since creation (the test suites fail on any).
  uint64_t validation_error_count() const;
  std::vector<std::string> validation_errors() const;

  const std::map<std::string, ProfileEntry>& profile() const { return profile_; }
  void add_profile_sample(const std::string& kernel, double ms);
  void clear_profile() { profile_.clear(); }

  const MemoryStats& memory_stats() const { return memory_; }
  // Recycling of device buffers (gpu/buffer.h): a released buffer goes back to the context, and a new buffer of the
  // same size and use takes it instead of a fresh vkAllocateMemory (an iteration's temporaries have the same sizes
  // every time). Pooled memory stays counted in memory_stats(). At most kPoolBytes and kPoolEntries are kept, the
  // oldest released first beyond that. key = (bytes, use).
  struct PooledBuffer {
    uint64_t bytes = 0, allocated_bytes = 0;
    int use = 0;
    void* mapped = nullptr;
    vk::raii::Buffer buffer = nullptr;
    vk::raii::DeviceMemory memory = nullptr;
  };
  static constexpr uint64_t kPoolBytes = 512ull << 20;
  static constexpr size_t kPoolEntries = 256;
  bool take_pooled(uint64_t bytes, int use, PooledBuffer& out);
  void give_back_buffer(PooledBuffer&& buffer);
  void release_pooled();  // frees every pooled buffer (memory measurements start from here)
  void note_allocation(uint64_t bytes);
  void note_free(uint64_t bytes);

  // Memory type index for `required` flags, preferring `preferred`; throws when none matches.
  uint32_t memory_type(uint32_t type_bits, vk::MemoryPropertyFlags required, vk::MemoryPropertyFlags preferred) const;
  // True when device-local memory is also host-visible and host-cached on this device (CPU drivers, integrated GPUs):
  // buffers are then mapped directly and no staging copy is needed. Not for a resizable BAR (host-visible but uncached:
  // host reads crawl across the bus), where transfers are staged.
  bool unified_memory() const { return unified_memory_; }
  bool force_staging() const { return force_staging_; }

  // Pipelines by shader code and specialization constants (gpu/kernel.h): a kernel made again (each add/delete round
  // makes a new particle system of some 20 kernels) shares the pipeline made first instead of compiling it again,
  // which on lavapipe costs LLVM time at creation and at the first dispatch (0.1-0.2 s a particle system). The
  // pipeline is opaque here; `make` builds it when missing. Kept until the context goes.
  std::shared_ptr<void> cached_pipeline(const void* code, const std::vector<uint32_t>& spec_constants,
                                        const std::function<std::shared_ptr<void>()>& make);

  const vk::raii::Device& device() const { return device_; }
  const vk::raii::Queue& queue() const { return queue_; }
  const vk::raii::CommandPool& command_pool() const { return command_pool_; }
  const vk::raii::PhysicalDevice& physical_device() const { return physical_device_; }
  uint32_t queue_family() const { return queue_family_; }
  uint32_t timestamp_valid_bits() const { return timestamp_valid_bits_; }

 struct Validation;  // validation message sink (opaque; public so the messenger callback can reach it)

 private:
  DeviceInfo info_;
  bool validation_enabled_ = false;
  bool profiling_ = false;
  bool unified_memory_ = false;
  bool force_staging_ = false;
  uint32_t queue_family_ = 0;
  uint32_t timestamp_valid_bits_ = 0;
  vk::PhysicalDeviceMemoryProperties memory_properties_;
  std::map<std::string, ProfileEntry> profile_;
  MemoryStats memory_;
  std::unique_ptr<Validation> validation_;  // outlives the messenger below (declared earlier, destroyed later)

  // Declared in creation order so that they are destroyed in reverse.
  vk::raii::Context vk_context_;
  vk::raii::Instance instance_ = nullptr;
  vk::raii::DebugUtilsMessengerEXT messenger_ = nullptr;
  vk::raii::PhysicalDevice physical_device_ = nullptr;
  vk::raii::Device device_ = nullptr;
  vk::raii::Queue queue_ = nullptr;
  vk::raii::CommandPool command_pool_ = nullptr;
  // After the device: destroyed before it.
  std::mutex pool_mutex_;
  std::vector<PooledBuffer> pool_;  // oldest first
  uint64_t pooled_bytes_ = 0;
  std::mutex pipeline_mutex_;
  std::map<std::pair<const void*, std::vector<uint32_t>>, std::shared_ptr<void>> pipelines_;
};

}  // namespace cpmesh::gpu
