// cpmesh: the command-line tool. Each subcommand is a thin layer over the engine library.
#include <cstdio>
#include <iostream>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "gpu/describe.h"
#include "primitives/selftest.h"

namespace {

using namespace cpmesh;

struct GlobalOptions {
  std::string device;
  bool profile = false;
  bool validation = false;
};

gpu::ContextOptions context_options(const GlobalOptions& g) {
  return gpu::ContextOptions{g.device, g.validation, g.profile};
}

void print_profile(const gpu::Context& ctx, const GlobalOptions& g) {
  if (g.profile) std::cout << '\n' << gpu::format_profile(ctx);
}

int run_devices(const GlobalOptions& g, bool json) {
  const auto devices = gpu::list_devices();
  std::string selector = g.device, source = "--device";
  if (selector.empty() && std::getenv("CPMESH_DEVICE")) {
    selector = std::getenv("CPMESH_DEVICE");
    source = "CPMESH_DEVICE";
  }
  int chosen = -1;
  std::string choice_error;
  try {
    chosen = int(gpu::select_device(devices, selector, source));
  } catch (const gpu::Error& e) {
    choice_error = e.what();
  }
  if (json) {
    nlohmann::json j = {{"devices", nlohmann::json::array()}, {"selected", chosen}};
    for (const auto& d : devices) j["devices"].push_back(gpu::device_json(d));
    std::cout << j.dump(2) << '\n';
  } else {
    std::cout << devices.size() << " Vulkan device" << (devices.size() == 1 ? "" : "s")
              << " (* = the one cpmesh uses; override with --device INDEX|NAME or CPMESH_DEVICE)\n";
    for (const auto& d : devices) std::cout << gpu::format_device(d, int(d.index) == chosen);
  }
  if (!choice_error.empty()) {
    std::cerr << "cpmesh: " << choice_error << '\n';
    return 1;
  }
  return 0;
}

int run_selftest(const GlobalOptions& g, uint32_t n) {
  gpu::Context ctx(context_options(g));
  std::cout << "Self-test of the GPU building blocks on " << ctx.info().name << " (" << n << " values each)\n";
  bool all = true;
  for (const auto& r : gpu::run_selftest(ctx, n)) {
    std::printf("  %-20s %-4s %9.2f ms  %s\n", r.name.c_str(), r.passed ? "ok" : "FAIL", r.ms, r.detail.c_str());
    all = all && r.passed;
  }
  if (ctx.validation_enabled())
    std::printf("  validation errors: %llu\n", (unsigned long long)ctx.validation_error_count());
  all = all && ctx.validation_error_count() == 0;
  print_profile(ctx, g);
  std::cout << (all ? "all building blocks agree with their C++ references\n" : "SELF-TEST FAILED\n");
  return all ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cpmesh " CPMESH_VERSION
               ": conforming multi-material surface and tetrahedral meshes from labeled volumes,\n"
               "with a GPU particle system (Vulkan; runs on any Vulkan 1.2 device, lavapipe included).",
               "cpmesh"};
  app.set_version_flag("--version", std::string("cpmesh ") + CPMESH_VERSION);
  app.require_subcommand(1);
  app.fallthrough();  // global options may follow the subcommand

  GlobalOptions g;
  app.add_option("--device", g.device,
                 "Vulkan device: an index or a part of a name from `cpmesh devices` (default: CPMESH_DEVICE, else "
                 "discrete > integrated > virtual > CPU)");
  app.add_flag("--profile", g.profile, "Print GPU time per kernel (timestamp queries) when done");
  app.add_flag("--validation", g.validation,
               "Enable the Vulkan validation layers (also CPMESH_VALIDATION=1); slow, for debugging");

  bool devices_json = false;
  auto* devices = app.add_subcommand("devices", "List Vulkan devices with the limits cpmesh depends on");
  devices->add_flag("--json", devices_json, "Print JSON instead of text");

  uint32_t selftest_n = 1u << 20;
  auto* selftest = app.add_subcommand(
      "selftest", "Run every GPU building block (scan, reductions, compaction, radix sorts) against its C++ reference");
  selftest->add_option("-n,--size", selftest_n, "Values per building block")->check(CLI::Range(0u, 1u << 26));

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  try {
    if (devices->parsed()) return run_devices(g, devices_json);
    if (selftest->parsed()) return run_selftest(g, selftest_n);
  } catch (const std::exception& e) {
    std::cerr << "cpmesh: error: " << e.what() << '\n';
    return 1;
  }
  return 0;
}
