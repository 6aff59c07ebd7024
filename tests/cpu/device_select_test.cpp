// Device choice rules (gpu::select_device) on made-up device lists: no GPU needed.
#include <doctest/doctest.h>

#include "gpu/context.h"

using namespace cpmesh;

namespace {
gpu::DeviceInfo device(uint32_t index, const char* name, const char* type, bool usable = true) {
  gpu::DeviceInfo d;
  d.index = index;
  d.name = name;
  d.type = type;
  d.usable = usable;
  if (!usable) d.unusable_reason = "Vulkan 1.1.0 < 1.2";
  return d;
}
}  // namespace

TEST_CASE("automatic choice: discrete, then integrated, then virtual, then CPU") {
  const std::vector<gpu::DeviceInfo> all = {device(0, "llvmpipe (LLVM 15)", "cpu"), device(1, "Intel UHD 630", "integrated"),
                                            device(2, "NVIDIA H100", "discrete"), device(3, "virtio", "virtual")};
  CHECK(gpu::select_device(all, "") == 2);
  CHECK(gpu::select_device({all[0], all[1], all[3]}, "") == 1);
  CHECK(gpu::select_device({all[0], all[3]}, "") == 3);
  CHECK(gpu::select_device({all[0]}, "") == 0);
}

TEST_CASE("unusable devices are skipped automatically and refused by name") {
  const std::vector<gpu::DeviceInfo> all = {device(0, "Old GPU", "discrete", false), device(1, "llvmpipe", "cpu")};
  CHECK(gpu::select_device(all, "") == 1);
  CHECK_THROWS_WITH_AS(gpu::select_device(all, "old"), doctest::Contains("cannot use"), gpu::Error);
  CHECK_THROWS_WITH_AS(gpu::select_device({all[0]}, ""), doctest::Contains("no usable Vulkan device"), gpu::Error);
  CHECK_THROWS_WITH_AS(gpu::select_device({}, ""), doctest::Contains("mesa-vulkan-drivers"), gpu::Error);
}

TEST_CASE("explicit choice by index or case-insensitive name substring") {
  const std::vector<gpu::DeviceInfo> all = {device(0, "llvmpipe (LLVM 15)", "cpu"), device(1, "NVIDIA H100", "discrete")};
  CHECK(gpu::select_device(all, "0") == 0);
  CHECK(gpu::select_device(all, "1") == 1);
  CHECK(gpu::select_device(all, "LLVMpipe") == 0);
  CHECK(gpu::select_device(all, "h100") == 1);
  CHECK_THROWS_WITH_AS(gpu::select_device(all, "7"), doctest::Contains("matches no Vulkan device"), gpu::Error);
  // The message lists what is there, and names where the selector came from.
  CHECK_THROWS_WITH_AS(gpu::select_device(all, "radeon", "CPMESH_DEVICE"),
                       doctest::Contains("CPMESH_DEVICE 'radeon'"), gpu::Error);
  CHECK_THROWS_WITH_AS(gpu::select_device(all, "radeon"), doctest::Contains("1: NVIDIA H100 (discrete)"), gpu::Error);
}
