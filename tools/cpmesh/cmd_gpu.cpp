// `cpmesh devices` and `cpmesh selftest`.
#include <cstdio>
#include <iostream>
#include <memory>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "gpu/describe.h"
#include "primitives/selftest.h"

namespace cpmesh::cli {

void print_profile(const gpu::Context& ctx, const GlobalOptions& g) {
  if (g.profile) std::cout << '\n' << gpu::format_profile(ctx);
}

Command add_devices_command(CLI::App& app, const GlobalOptions& g) {
  auto json = std::make_shared<bool>(false);
  auto* sub = app.add_subcommand("devices", "List Vulkan devices with the limits cpmesh depends on");
  sub->add_flag("--json", *json, "Print JSON instead of text");
  return {sub, [&g, json] {
            const auto devices = gpu::list_devices();
            int chosen = -1;
            std::string choice_error;
            try {
              chosen = int(gpu::choose_device(devices, g.device));
            } catch (const gpu::Error& e) {
              choice_error = e.what();
            }
            if (*json) {
              nlohmann::json j = {{"devices", nlohmann::json::array()}, {"selected", chosen}};
              for (const auto& d : devices) j["devices"].push_back(gpu::device_json(d));
              std::cout << j.dump(2) << '\n';
            } else {
              std::cout << devices.size() << " Vulkan device" << (devices.size() == 1 ? "" : "s")
                        << " (* = the one cpmesh uses; override with --device INDEX|NAME or CPMESH_DEVICE)\n";
              for (const auto& d : devices) std::cout << gpu::format_device(d, int(d.index) == chosen);
            }
            if (!choice_error.empty()) {
              std::cerr << "cpmesh: error: " << choice_error << '\n';
              return 1;
            }
            return 0;
          }};
}

Command add_selftest_command(CLI::App& app, const GlobalOptions& g) {
  auto n = std::make_shared<uint32_t>(1u << 20);
  auto* sub = app.add_subcommand(
      "selftest", "Run every GPU building block (scan, reductions, compaction, radix sorts) against its C++ reference");
  sub->add_option("-n,--size", *n, "Values per building block")->check(CLI::Range(0u, 1u << 24))->capture_default_str();
  return {sub, [&g, n] {
            gpu::Context ctx(g.context());
            std::cout << "Self-test of the GPU building blocks on " << ctx.info().name << " (" << *n
                      << " values each)\n";
            bool all = true;
            for (const auto& r : gpu::run_selftest(ctx, *n)) {
              std::printf("  %-20s %-4s %9.2f ms  %s\n", r.name.c_str(), r.passed ? "ok" : "FAIL", r.ms,
                          r.detail.c_str());
              all = all && r.passed;
            }
            if (ctx.validation_enabled())
              std::printf("  validation errors: %llu\n", (unsigned long long)ctx.validation_error_count());
            all = all && ctx.validation_error_count() == 0;
            print_profile(ctx, g);
            std::cout << (all ? "all building blocks agree with their C++ references\n" : "SELF-TEST FAILED\n");
            return all ? 0 : 1;
          }};
}

}  // namespace cpmesh::cli
