#pragma once
#include <functional>
#include <string>

#include "gpu/context.h"

namespace cpmesh::gpu {

// Records `record` into a fresh command buffer, submits it and waits; with a barrier that makes its writes visible to
// the host. For one-off transfers; repeated work belongs in a Sequence.
void submit_once(Context& ctx, const std::string& doing, const std::function<void(const vk::raii::CommandBuffer&)>& record);

// The barrier recorded between dependent commands: all compute/transfer writes visible to later compute, transfer,
// indirect-argument and host reads.
void full_barrier(const vk::raii::CommandBuffer& cb);

}  // namespace cpmesh::gpu
