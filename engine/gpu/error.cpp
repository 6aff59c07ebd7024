#include "gpu/vk.h"

namespace cpmesh::gpu {

std::string describe_vk_failure(int vk_result, std::string_view doing, std::string_view detail) {
  const auto r = static_cast<vk::Result>(vk_result);
  std::string advice;
  switch (r) {
    case vk::Result::eErrorOutOfDeviceMemory:
      advice = "the GPU ran out of memory; reduce the problem size (coarser --max-size, fewer labels) or pick a device "
               "with more memory (--device, `cpmesh devices`)";
      break;
    case vk::Result::eErrorOutOfHostMemory:
      advice = "the host ran out of memory; close other programs or reduce the problem size";
      break;
    case vk::Result::eErrorDeviceLost:
      advice = "the GPU device was lost (driver reset, a watchdog timeout on a long dispatch, or a driver fault); run "
               "again, try a smaller problem or another device (--device), and update the GPU driver";
      break;
    case vk::Result::eErrorInitializationFailed:
    case vk::Result::eErrorIncompatibleDriver:
      advice = "no usable Vulkan 1.2 driver was found; install one (on Debian: apt-get install mesa-vulkan-drivers for "
               "the CPU driver lavapipe, or your GPU vendor's driver)";
      break;
    case vk::Result::eErrorLayerNotPresent:
      advice = "a requested Vulkan layer is missing; install vulkan-validationlayers or run without validation";
      break;
    case vk::Result::eErrorExtensionNotPresent:
    case vk::Result::eErrorFeatureNotPresent:
      advice = "the device lacks a required extension or feature; pick another device (--device, `cpmesh devices`)";
      break;
    case vk::Result::eErrorTooManyObjects:
      advice = "the driver's object limit was reached; reduce the problem size";
      break;
    default:
      advice = "unexpected Vulkan failure; run with CPMESH_VALIDATION=1 for details and report it";
      break;
  }
  std::string msg = "GPU error while " + std::string(doing) + ": " + vk::to_string(r) + ": " + advice;
  if (!detail.empty()) msg += " [" + std::string(detail) + "]";
  return msg;
}

}  // namespace cpmesh::gpu
