#pragma once
// GPU runtime errors. Every Vulkan failure leaves the runtime as a gpu::Error whose message says what was being done,
// what went wrong and what the user can do about it.
#include <stdexcept>
#include <string>
#include <string_view>

namespace cpmesh::gpu {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Builds the user-facing message for a failed Vulkan call made while `doing` (e.g. "creating buffer 'keys'").
// `vk_result` is a VkResult value; `detail` is the driver's text, if any.
std::string describe_vk_failure(int vk_result, std::string_view doing, std::string_view detail = {});

// Runs f(); any vk::SystemError it throws becomes a gpu::Error with describe_vk_failure's message.
template <class F>
decltype(auto) guarded(std::string_view doing, F&& f);

}  // namespace cpmesh::gpu
