// `cpmesh info`: what a labeled volume holds, read on the host (no GPU).
#include <iostream>
#include <memory>

#include "commands.h"
#include "io/volume_info.h"
#include "volume_input.h"

namespace cpmesh::cli {

Command add_info_command(CLI::App& app, const GlobalOptions&) {
  struct Options {
    VolumeInput input;
    int64_t few_voxels = 64;
  };
  auto o = std::make_shared<Options>();
  auto* sub = app.add_subcommand(
      "info", "Describe a labeled volume: dims, spacing, origin, type, and per label its voxel count, bounding box and "
              "6-connected neighbour labels");
  add_volume_input(sub, o->input);
  sub->add_option("--few-voxels", o->few_voxels, "Warn about labels with fewer voxels than this")->capture_default_str();
  return {sub, [o] {
            std::cout << io::format_volume_info(io::summarize(read_volume_input(o->input)), o->few_voxels);
            return 0;
          }};
}

}  // namespace cpmesh::cli
