#include "gpu/context.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace cpmesh::gpu {

struct Context::Validation {
  mutable std::mutex mutex;
  std::vector<std::string> errors;
};

namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";
constexpr const char* kAtomicFloatExt = VK_EXT_SHADER_ATOMIC_FLOAT_EXTENSION_NAME;

vk::ApplicationInfo app_info() {
  return vk::ApplicationInfo("cpmesh", VK_MAKE_API_VERSION(0, 0, 1, 0), "cpmesh", VK_MAKE_API_VERSION(0, 0, 1, 0),
                             VK_API_VERSION_1_2);
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

bool has_extension(const vk::raii::PhysicalDevice& pd, const char* name) {
  for (const auto& e : pd.enumerateDeviceExtensionProperties())
    if (std::strcmp(e.extensionName, name) == 0) return true;
  return false;
}

int compute_queue_family(const vk::raii::PhysicalDevice& pd, uint32_t* timestamp_bits) {
  const auto families = pd.getQueueFamilyProperties();
  // A compute-only family first (async compute on discrete GPUs), else any family with compute.
  int best = -1;
  for (uint32_t i = 0; i < families.size(); ++i) {
    const auto f = families[i].queueFlags;
    if (!(f & vk::QueueFlagBits::eCompute)) continue;
    if (best < 0 || !(f & vk::QueueFlagBits::eGraphics)) best = int(i);
  }
  if (best >= 0 && timestamp_bits) *timestamp_bits = families[best].timestampValidBits;
  return best;
}

const char* type_name(vk::PhysicalDeviceType t) {
  switch (t) {
    case vk::PhysicalDeviceType::eDiscreteGpu: return "discrete";
    case vk::PhysicalDeviceType::eIntegratedGpu: return "integrated";
    case vk::PhysicalDeviceType::eVirtualGpu: return "virtual";
    case vk::PhysicalDeviceType::eCpu: return "cpu";
    default: return "other";
  }
}

int type_rank(const std::string& type) {
  if (type == "discrete") return 0;
  if (type == "integrated") return 1;
  if (type == "virtual") return 2;
  if (type == "cpu") return 3;
  return 4;
}

DeviceInfo describe(const vk::raii::PhysicalDevice& pd, uint32_t index) {
  DeviceInfo d;
  d.index = index;
  const auto chain = pd.getProperties2<vk::PhysicalDeviceProperties2, vk::PhysicalDeviceSubgroupProperties,
                                       vk::PhysicalDeviceDriverProperties>();
  const auto& p = chain.get<vk::PhysicalDeviceProperties2>().properties;
  d.name = p.deviceName.data();
  d.type = type_name(p.deviceType);
  d.api_version = p.apiVersion;
  const auto& drv = chain.get<vk::PhysicalDeviceDriverProperties>();
  d.driver = std::string(drv.driverName.data()) + " " + drv.driverInfo.data();
  d.max_storage_buffer_range = p.limits.maxStorageBufferRange;
  d.max_texel_buffer_elements = p.limits.maxTexelBufferElements;
  d.max_shared_memory = p.limits.maxComputeSharedMemorySize;
  d.max_workgroup_invocations = p.limits.maxComputeWorkGroupInvocations;
  for (int i = 0; i < 3; ++i) d.max_workgroup_count[i] = p.limits.maxComputeWorkGroupCount[i];
  d.subgroup_size = chain.get<vk::PhysicalDeviceSubgroupProperties>().subgroupSize;
  d.timestamp_period_ns = p.limits.timestampPeriod;
  if (p.apiVersion >= VK_API_VERSION_1_1) {
    const auto m = pd.getProperties2<vk::PhysicalDeviceProperties2, vk::PhysicalDeviceMaintenance3Properties>();
    d.max_memory_allocation_size = m.get<vk::PhysicalDeviceMaintenance3Properties>().maxMemoryAllocationSize;
  }
  const auto f = pd.getFeatures();
  d.shader_int64 = f.shaderInt64;
  d.shader_float64 = f.shaderFloat64;
  if (has_extension(pd, kAtomicFloatExt)) {
    const auto fc = pd.getFeatures2<vk::PhysicalDeviceFeatures2, vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT>();
    const auto& af = fc.get<vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT>();
    d.float_atomic_add_buffer = af.shaderBufferFloat32AtomicAdd;
    d.float_atomic_add_shared = af.shaderSharedFloat32AtomicAdd;
  }
  const auto mem = pd.getMemoryProperties();
  for (uint32_t i = 0; i < mem.memoryHeapCount; ++i)
    d.heaps.push_back({mem.memoryHeaps[i].size, bool(mem.memoryHeaps[i].flags & vk::MemoryHeapFlagBits::eDeviceLocal)});
  uint32_t ts_bits = 0;
  const int family = compute_queue_family(pd, &ts_bits);
  d.timestamps = family >= 0 && ts_bits > 0 && d.timestamp_period_ns > 0;
  if (p.apiVersion < VK_API_VERSION_1_2) {
    d.unusable_reason = "Vulkan " + format_version(p.apiVersion) + " < 1.2";
  } else if (family < 0) {
    d.unusable_reason = "no compute queue";
  } else {
    d.usable = true;
  }
  return d;
}

vk::raii::Instance make_instance(const vk::raii::Context& ctx, bool validation) {
  const auto app = app_info();
  std::vector<const char*> layers, extensions;
  if (validation) {
    layers.push_back(kValidationLayer);
    extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  }
  return vk::raii::Instance(ctx, vk::InstanceCreateInfo({}, &app, layers, extensions));
}

bool layer_available(const vk::raii::Context& ctx, const char* name) {
  for (const auto& l : ctx.enumerateInstanceLayerProperties())
    if (std::strcmp(l.layerName, name) == 0) return true;
  return false;
}

bool env_flag(const char* name) {
  const char* v = std::getenv(name);
  return v && *v && std::strcmp(v, "0") != 0 && lower(v) != "false" && lower(v) != "off";
}

std::string device_list_text(const std::vector<DeviceInfo>& all) {
  std::string s;
  for (const auto& d : all)
    s += "\n  " + std::to_string(d.index) + ": " + d.name + " (" + d.type + (d.usable ? "" : ", " + d.unusable_reason) + ")";
  return s.empty() ? "\n  (none)" : s;
}

}  // namespace

uint32_t select_device(const std::vector<DeviceInfo>& all, const std::string& selector, const std::string& source) {
  if (!selector.empty()) {
    const bool numeric = std::all_of(selector.begin(), selector.end(), [](unsigned char c) { return std::isdigit(c); });
    for (const auto& d : all) {
      const bool hit = numeric ? std::to_string(d.index) == selector : lower(d.name).find(lower(selector)) != std::string::npos;
      if (!hit) continue;
      if (!d.usable) throw Error(source + " '" + selector + "' selects device " + std::to_string(d.index) + " (" + d.name +
                                 "), which cpmesh cannot use: " + d.unusable_reason);
      return d.index;
    }
    throw Error(source + " '" + selector + "' matches no Vulkan device; expected an index or a part of a name from:" +
                device_list_text(all));
  }
  const DeviceInfo* best = nullptr;
  for (const auto& d : all)
    if (d.usable && (!best || type_rank(d.type) < type_rank(best->type))) best = &d;
  if (!best) throw Error("no usable Vulkan device (Vulkan 1.2 with a compute queue) was found:" + device_list_text(all) +
                         "\nInstall a driver: on Debian, apt-get install mesa-vulkan-drivers gives the CPU driver lavapipe.");
  return best->index;
}

uint32_t choose_device(const std::vector<DeviceInfo>& all, const std::string& option) {
  const char* env = std::getenv("CPMESH_DEVICE");
  if (option.empty() && env && *env) return select_device(all, env, "CPMESH_DEVICE");
  return select_device(all, option, "--device");
}

namespace {

VKAPI_ATTR VkBool32 VKAPI_CALL on_validation_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                     VkDebugUtilsMessageTypeFlagsEXT,
                                                     const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  auto* v = static_cast<Context::Validation*>(user);
  const char* msg = data && data->pMessage ? data->pMessage : "(no message)";
  if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) {
    std::lock_guard lock(v->mutex);
    v->errors.emplace_back(msg);
    std::fprintf(stderr, "cpmesh: Vulkan validation error: %s\n", msg);
  } else if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
    std::fprintf(stderr, "cpmesh: Vulkan validation warning: %s\n", msg);
  }
  return VK_FALSE;
}

}  // namespace

std::string format_version(uint32_t v) {
  return std::to_string(VK_API_VERSION_MAJOR(v)) + "." + std::to_string(VK_API_VERSION_MINOR(v)) + "." +
         std::to_string(VK_API_VERSION_PATCH(v));
}

std::vector<DeviceInfo> list_devices() {
  return guarded("listing Vulkan devices", [] {
    vk::raii::Context ctx;
    vk::raii::Instance instance = make_instance(ctx, false);
    std::vector<DeviceInfo> out;
    uint32_t i = 0;
    for (const auto& pd : vk::raii::PhysicalDevices(instance)) out.push_back(describe(pd, i++));
    return out;
  });
}

Context::Context(const ContextOptions& options) : validation_(std::make_unique<Validation>()) {
  guarded("creating the Vulkan instance", [&] {
    const bool want_validation = options.validation || env_flag("CPMESH_VALIDATION");
    validation_enabled_ = want_validation && layer_available(vk_context_, kValidationLayer);
    if (want_validation && !validation_enabled_)
      std::fprintf(stderr, "cpmesh: warning: validation requested but %s is not installed (apt-get install "
                           "vulkan-validationlayers); running without it\n", kValidationLayer);
    instance_ = make_instance(vk_context_, validation_enabled_);
    if (validation_enabled_) {
      using S = vk::DebugUtilsMessageSeverityFlagBitsEXT;
      using T = vk::DebugUtilsMessageTypeFlagBitsEXT;
      messenger_ = vk::raii::DebugUtilsMessengerEXT(
          instance_, vk::DebugUtilsMessengerCreateInfoEXT({}, S::eError | S::eWarning,
                                                          T::eGeneral | T::eValidation | T::ePerformance,
                                                          &on_validation_message, validation_.get()));
    }
  });

  vk::raii::PhysicalDevices physical(instance_);
  std::vector<DeviceInfo> all;
  for (uint32_t i = 0; i < physical.size(); ++i) all.push_back(describe(physical[i], i));
  const uint32_t chosen = choose_device(all, options.device);
  info_ = all[chosen];
  if (options.max_workgroups_x)
    info_.max_workgroup_count[0] = std::min(info_.max_workgroup_count[0], options.max_workgroups_x);
  physical_device_ = std::move(physical[chosen]);
  queue_family_ = uint32_t(compute_queue_family(physical_device_, &timestamp_valid_bits_));
  profiling_ = options.profile && info_.timestamps;
  if (options.profile && !info_.timestamps)
    std::fprintf(stderr, "cpmesh: warning: %s has no timestamp queries on its compute queue; --profile is off\n",
                 info_.name.c_str());

  guarded("creating the Vulkan device on " + info_.name, [&] {
    const float priority = 1.0f;
    vk::DeviceQueueCreateInfo queue_info({}, queue_family_, 1, &priority);
    vk::PhysicalDeviceFeatures features;
    features.shaderInt64 = info_.shader_int64;
    features.shaderFloat64 = info_.shader_float64;
    vk::StructureChain<vk::DeviceCreateInfo, vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT> chain;
    std::vector<const char*> extensions;
    auto& atomic = chain.get<vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT>();
    if (info_.float_atomic_add_buffer || info_.float_atomic_add_shared) {
      extensions.push_back(kAtomicFloatExt);
      atomic.shaderBufferFloat32AtomicAdd = info_.float_atomic_add_buffer;
      atomic.shaderSharedFloat32AtomicAdd = info_.float_atomic_add_shared;
    } else {
      chain.unlink<vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT>();
    }
    chain.get<vk::DeviceCreateInfo>().setQueueCreateInfos(queue_info).setPEnabledExtensionNames(extensions)
        .setPEnabledFeatures(&features);
    device_ = vk::raii::Device(physical_device_, chain.get<vk::DeviceCreateInfo>());
    queue_ = vk::raii::Queue(device_, queue_family_, 0);
    command_pool_ = vk::raii::CommandPool(
        device_, vk::CommandPoolCreateInfo(vk::CommandPoolCreateFlagBits::eResetCommandBuffer, queue_family_));
  });

  memory_properties_ = physical_device_.getMemoryProperties();
  force_staging_ = options.force_staging;
  // Unified when some memory type is device-local, host-visible and host-cached in a heap as large as the largest
  // device-local heap (so not a 256 MiB BAR window). Cached matters: a discrete GPU with resizable BAR exposes its
  // whole memory as device-local and host-visible but uncached, and the host reads that across the bus without a
  // cache, tens of MB/s (a 1.67 M particle population took about a second a download); staging copies instead.
  uint64_t largest_local = 0;
  for (uint32_t i = 0; i < memory_properties_.memoryHeapCount; ++i)
    if (memory_properties_.memoryHeaps[i].flags & vk::MemoryHeapFlagBits::eDeviceLocal)
      largest_local = std::max<uint64_t>(largest_local, memory_properties_.memoryHeaps[i].size);
  const auto both = vk::MemoryPropertyFlagBits::eDeviceLocal | vk::MemoryPropertyFlagBits::eHostVisible |
                    vk::MemoryPropertyFlagBits::eHostCoherent | vk::MemoryPropertyFlagBits::eHostCached;
  for (uint32_t i = 0; i < memory_properties_.memoryTypeCount; ++i) {
    const auto& t = memory_properties_.memoryTypes[i];
    if ((t.propertyFlags & both) == both && memory_properties_.memoryHeaps[t.heapIndex].size >= largest_local)
      unified_memory_ = !force_staging_;
  }
}

Context::~Context() {
  if (*device_) device_.waitIdle();
  pool_.clear();
  pipelines_.clear();
}

std::shared_ptr<void> Context::cached_pipeline(const void* code, const std::vector<uint32_t>& spec_constants,
                                               const std::function<std::shared_ptr<void>()>& make) {
  std::lock_guard lock(pipeline_mutex_);
  auto& slot = pipelines_[{code, spec_constants}];
  if (!slot) slot = make();
  return slot;
}

uint64_t Context::validation_error_count() const {
  std::lock_guard lock(validation_->mutex);
  return validation_->errors.size();
}

std::vector<std::string> Context::validation_errors() const {
  std::lock_guard lock(validation_->mutex);
  return validation_->errors;
}

void Context::add_profile_sample(const std::string& kernel, double ms) {
  auto& e = profile_[kernel];
  e.dispatches += 1;
  e.total_ms += ms;
}

void Context::note_allocation(uint64_t bytes) {
  memory_.current_bytes += bytes;
  memory_.peak_bytes = std::max(memory_.peak_bytes, memory_.current_bytes);
  memory_.allocations += 1;
}

void Context::note_free(uint64_t bytes) { memory_.current_bytes -= std::min(bytes, memory_.current_bytes); }

bool Context::take_pooled(uint64_t bytes, int use, PooledBuffer& out) {
  std::lock_guard lock(pool_mutex_);
  for (size_t i = pool_.size(); i-- > 0;) {  // the most recently released first
    if (pool_[i].bytes != bytes || pool_[i].use != use) continue;
    out = std::move(pool_[i]);
    pool_.erase(pool_.begin() + long(i));
    pooled_bytes_ -= out.allocated_bytes;
    return true;
  }
  return false;
}

void Context::release_pooled() {
  std::lock_guard lock(pool_mutex_);
  for (const auto& p : pool_) note_free(p.allocated_bytes);
  pool_.clear();
  pooled_bytes_ = 0;
}

void Context::give_back_buffer(PooledBuffer&& buffer) {
  std::lock_guard lock(pool_mutex_);
  pooled_bytes_ += buffer.allocated_bytes;
  pool_.push_back(std::move(buffer));
  while (!pool_.empty() && (pooled_bytes_ > kPoolBytes || pool_.size() > kPoolEntries)) {
    pooled_bytes_ -= pool_.front().allocated_bytes;
    note_free(pool_.front().allocated_bytes);
    pool_.erase(pool_.begin());
  }
}

uint32_t Context::memory_type(uint32_t type_bits, vk::MemoryPropertyFlags required,
                              vk::MemoryPropertyFlags preferred) const {
  int fallback = -1;
  for (uint32_t i = 0; i < memory_properties_.memoryTypeCount; ++i) {
    if (!(type_bits & (1u << i))) continue;
    const auto flags = memory_properties_.memoryTypes[i].propertyFlags;
    if ((flags & required) != required) continue;
    if ((flags & preferred) == preferred) return i;
    if (fallback < 0) fallback = int(i);
  }
  if (fallback < 0)
    throw Error("the device " + info_.name + " has no memory type with " + vk::to_string(required) +
                " for this buffer");
  return uint32_t(fallback);
}

}  // namespace cpmesh::gpu
