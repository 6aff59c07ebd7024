// Vulkan failures become messages a user can act on.
#include <doctest/doctest.h>

#include <string>
#include <vulkan/vulkan_core.h>

#include "gpu/error.h"

using cpmesh::gpu::describe_vk_failure;

TEST_CASE("Vulkan failures are described with what was being done and what to do") {
  const auto oom = describe_vk_failure(VK_ERROR_OUT_OF_DEVICE_MEMORY, "creating buffer 'keys'");
  CHECK(oom.find("creating buffer 'keys'") != std::string::npos);
  CHECK(oom.find("ErrorOutOfDeviceMemory") != std::string::npos);
  CHECK(oom.find("--device") != std::string::npos);
  const auto lost = describe_vk_failure(VK_ERROR_DEVICE_LOST, "waiting for GPU work", "vkWaitForFences");
  CHECK(lost.find("device was lost") != std::string::npos);
  CHECK(lost.find("[vkWaitForFences]") != std::string::npos);
  const auto driver = describe_vk_failure(VK_ERROR_INCOMPATIBLE_DRIVER, "creating the Vulkan instance");
  CHECK(driver.find("mesa-vulkan-drivers") != std::string::npos);
  const auto feature = describe_vk_failure(VK_ERROR_FEATURE_NOT_PRESENT, "creating the Vulkan device");
  CHECK(feature.find("lacks a required extension or feature") != std::string::npos);
}
