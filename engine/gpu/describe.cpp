#include "gpu/describe.h"

#include <algorithm>
#include <cstdio>
#include <vector>

namespace cpmesh::gpu {

std::string format_bytes(uint64_t bytes) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB"};
  double v = double(bytes);
  int u = 0;
  while (v >= 1024.0 && u < 4) {
    v /= 1024.0;
    ++u;
  }
  char s[32];
  std::snprintf(s, sizeof s, u == 0 ? "%.0f %s" : "%.1f %s", v, units[u]);
  return s;
}

std::string format_device(const DeviceInfo& d, bool chosen) {
  auto yes = [](bool b) { return b ? "yes" : "no"; };
  char buf[2048];
  std::snprintf(buf, sizeof buf,
                "%s %u: %s (%s, Vulkan %s)%s\n"
                "    driver                        %s\n"
                "    max storage buffer range      %s\n"
                "    max texel buffer texels       %llu\n"
                "    max memory allocation         %s\n"
                "    shared memory per workgroup   %s\n"
                "    max workgroup invocations     %u\n"
                "    max workgroup count           %u x %u x %u\n"
                "    subgroup size                 %u\n"
                "    float32 atomic add            buffer %s, shared %s\n"
                "    shader int64 / float64        %s / %s\n"
                "    timestamps                    %s",
                chosen ? "*" : " ", d.index, d.name.c_str(), d.type.c_str(), format_version(d.api_version).c_str(),
                d.usable ? (chosen ? "  [selected]" : "") : ("  [unusable: " + d.unusable_reason + "]").c_str(),
                d.driver.c_str(), format_bytes(d.max_storage_buffer_range).c_str(),
                (unsigned long long)d.max_texel_buffer_elements, format_bytes(d.max_memory_allocation_size).c_str(),
                format_bytes(d.max_shared_memory).c_str(),
                d.max_workgroup_invocations, d.max_workgroup_count[0], d.max_workgroup_count[1],
                d.max_workgroup_count[2], d.subgroup_size, yes(d.float_atomic_add_buffer),
                yes(d.float_atomic_add_shared), yes(d.shader_int64), yes(d.shader_float64), yes(d.timestamps));
  std::string s = buf;
  if (d.timestamps) {
    std::snprintf(buf, sizeof buf, " (period %.3g ns)", d.timestamp_period_ns);
    s += buf;
  }
  s += "\n";
  for (size_t i = 0; i < d.heaps.size(); ++i) {
    std::snprintf(buf, sizeof buf, "    memory heap %zu                 %s%s\n", i, format_bytes(d.heaps[i].size).c_str(),
                  d.heaps[i].device_local ? " (device local)" : "");
    s += buf;
  }
  return s;
}

nlohmann::json device_json(const DeviceInfo& d) {
  nlohmann::json heaps = nlohmann::json::array();
  for (const auto& h : d.heaps) heaps.push_back({{"bytes", h.size}, {"device_local", h.device_local}});
  return {{"index", d.index},
          {"name", d.name},
          {"type", d.type},
          {"api_version", format_version(d.api_version)},
          {"driver", d.driver},
          {"usable", d.usable},
          {"unusable_reason", d.unusable_reason},
          {"max_storage_buffer_range", d.max_storage_buffer_range},
          {"max_texel_buffer_elements", d.max_texel_buffer_elements},
          {"max_memory_allocation_size", d.max_memory_allocation_size},
          {"max_shared_memory", d.max_shared_memory},
          {"max_workgroup_invocations", d.max_workgroup_invocations},
          {"subgroup_size", d.subgroup_size},
          {"float_atomic_add_buffer", d.float_atomic_add_buffer},
          {"float_atomic_add_shared", d.float_atomic_add_shared},
          {"shader_int64", d.shader_int64},
          {"shader_float64", d.shader_float64},
          {"timestamps", d.timestamps},
          {"memory_heaps", heaps}};
}

namespace {
std::vector<std::pair<std::string, ProfileEntry>> by_time(const Context& ctx) {
  std::vector<std::pair<std::string, ProfileEntry>> rows(ctx.profile().begin(), ctx.profile().end());
  std::sort(rows.begin(), rows.end(), [](const auto& a, const auto& b) { return a.second.total_ms > b.second.total_ms; });
  return rows;
}
}  // namespace

std::string format_profile(const Context& ctx) {
  if (!ctx.profiling()) return "GPU profile: timestamps unavailable on " + ctx.info().name + "\n";
  std::string s = "GPU profile (" + ctx.info().name + ", timestamp queries per dispatch)\n";
  char buf[256];
  std::snprintf(buf, sizeof buf, "  %-28s %10s %12s %12s\n", "kernel", "dispatches", "total ms", "mean us");
  s += buf;
  double total = 0;
  for (const auto& [name, e] : by_time(ctx)) {
    std::snprintf(buf, sizeof buf, "  %-28s %10llu %12.3f %12.1f\n", name.c_str(), (unsigned long long)e.dispatches,
                  e.total_ms, 1000.0 * e.total_ms / double(std::max<uint64_t>(e.dispatches, 1)));
    s += buf;
    total += e.total_ms;
  }
  std::snprintf(buf, sizeof buf, "  %-28s %10s %12.3f\n", "all kernels", "", total);
  return s + buf;
}

nlohmann::json profile_json(const Context& ctx) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [name, e] : by_time(ctx)) j[name] = {{"dispatches", e.dispatches}, {"total_ms", e.total_ms}};
  return j;
}

}  // namespace cpmesh::gpu
