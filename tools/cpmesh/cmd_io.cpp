// `cpmesh info`: what a labeled volume holds, read on the host (no GPU).
#include <iostream>
#include <memory>

#include "commands.h"
#include "io/read_volume.h"
#include "io/volume_info.h"

namespace cpmesh::cli {

Command add_info_command(CLI::App& app, const GlobalOptions&) {
  struct Options {
    std::string path;
    std::vector<int64_t> raw_dims;
    std::vector<double> raw_spacing{1, 1, 1};
    std::string raw_type = "u8";
    bool raw_big_endian = false;
    int64_t few_voxels = 64;
  };
  auto o = std::make_shared<Options>();
  auto* sub = app.add_subcommand(
      "info", "Describe a labeled volume: dims, spacing, origin, type, and per label its voxel count, bounding box and "
              "6-connected neighbour labels");
  sub->add_option("volume", o->path, "Volume file (NRRD, NIfTI-1, MetaImage, INRIMAGE, gzip of these, or raw)")
      ->required();
  sub->add_option("--raw-dims", o->raw_dims, "Headerless raw: dims nx,ny,nz")->delimiter(',')->expected(3);
  sub->add_option("--raw-spacing", o->raw_spacing, "Headerless raw: spacing sx,sy,sz")->delimiter(',')->expected(3);
  sub->add_option("--raw-type", o->raw_type, "Headerless raw: u8, i8, u16, i16, u32 or i32")->capture_default_str();
  sub->add_flag("--raw-big-endian", o->raw_big_endian, "Headerless raw: samples are big-endian");
  sub->add_option("--few-voxels", o->few_voxels, "Warn about labels with fewer voxels than this")->capture_default_str();
  return {sub, [o] {
            io::RawOptions raw;
            const bool has_raw = !o->raw_dims.empty();
            if (has_raw) {
              raw.dims = {o->raw_dims[0], o->raw_dims[1], o->raw_dims[2]};
              raw.spacing = {o->raw_spacing[0], o->raw_spacing[1], o->raw_spacing[2]};
              raw.type = io::parse_scalar_type(o->raw_type, "--raw-type");
              raw.big_endian = o->raw_big_endian;
            }
            const io::LabelVolume v = io::read_label_volume(o->path, has_raw ? &raw : nullptr);
            std::cout << io::format_volume_info(io::summarize(v), o->few_voxels);
            return 0;
          }};
}

}  // namespace cpmesh::cli
