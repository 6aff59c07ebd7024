#pragma once
// The one place Vulkan-Hpp is configured and included. Engine sources include this, never <vulkan/...> directly.
#define VULKAN_HPP_NO_SPACESHIP_OPERATOR
#include <vulkan/vulkan_raii.hpp>

#include "gpu/error.h"

namespace cpmesh::gpu {

template <class F>
decltype(auto) guarded(std::string_view doing, F&& f) {
  try {
    return f();
  } catch (const vk::SystemError& e) {
    throw Error(describe_vk_failure(e.code().value(), doing, e.what()));
  }
}

}  // namespace cpmesh::gpu
