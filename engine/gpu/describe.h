#pragma once
// Human- and machine-readable descriptions of devices and profiles, shared by the CLI and the benchmarks.
#include <string>

#include <nlohmann/json.hpp>

#include "gpu/context.h"

namespace cpmesh::gpu {

std::string format_bytes(uint64_t bytes);                             // "1.5 GiB"
std::string format_device(const DeviceInfo& d, bool chosen);          // multi-line block for `cpmesh devices`
nlohmann::json device_json(const DeviceInfo& d);
std::string format_profile(const Context& ctx);                       // table: kernel, dispatches, total ms, mean us
nlohmann::json profile_json(const Context& ctx);

}  // namespace cpmesh::gpu
