// cpmesh: the command-line tool. Each subcommand (commands.h) is a thin layer over the engine library.
#include <iostream>
#include <memory>

#include <tbb/global_control.h>
#include <vector>

#include "commands.h"

int main(int argc, char** argv) {
  using namespace cpmesh::cli;
  CLI::App app{"cpmesh " CPMESH_VERSION
               ": conforming multi-material surface and tetrahedral meshes from labeled volumes,\n"
               "with a GPU particle system (Vulkan; runs on any Vulkan 1.2 device, lavapipe included).",
               "cpmesh"};
  app.set_version_flag("--version", std::string("cpmesh ") + CPMESH_VERSION);
  app.require_subcommand(1);
  app.fallthrough();  // global options may also follow the subcommand

  GlobalOptions g;
  app.add_option("--device", g.device,
                 "Vulkan device: an index or a part of a name from `cpmesh devices` (default: CPMESH_DEVICE, else "
                 "discrete > integrated > virtual > CPU)");
  app.add_flag("--profile", g.profile, "Print GPU time per kernel (timestamp queries) when done");
  unsigned threads = 0;
  app.add_option("--threads", threads, "CPU threads for the host stages (0: every core)")->capture_default_str();
  app.add_flag("--validation", g.validation,
               "Enable the Vulkan validation layers (also CPMESH_VALIDATION=1); slow, for debugging");

  const std::vector<Command> commands = {
      add_devices_command(app, g),
      add_selftest_command(app, g),
      add_info_command(app, g),
      add_fields_command(app, g),
      add_particles_command(app, g),
      add_mesh_command(app, g),
  };

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  std::unique_ptr<tbb::global_control> thread_limit;
  if (threads > 0)
    thread_limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
  try {
    for (const auto& c : commands)
      if (c.sub->parsed()) return c.run();
  } catch (const std::exception& e) {
    std::cerr << "cpmesh: error: " << e.what() << '\n';
    return 1;
  }
  return 0;
}
