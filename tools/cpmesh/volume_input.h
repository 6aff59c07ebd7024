#pragma once
// The volume argument shared by the subcommands that read a labeled volume, with the options for headerless raw.
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "io/volume.h"

namespace cpmesh::cli {

struct VolumeInput {
  std::string path;
  std::vector<int64_t> raw_dims;
  std::vector<double> raw_spacing{1, 1, 1};
  std::string raw_type = "u8";
  bool raw_big_endian = false;
};

void add_volume_input(CLI::App* sub, VolumeInput& in);
io::LabelVolume read_volume_input(const VolumeInput& in);

}  // namespace cpmesh::cli
