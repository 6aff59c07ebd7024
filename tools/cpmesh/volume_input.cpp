#include "volume_input.h"

#include "io/read_volume.h"

namespace cpmesh::cli {

void add_volume_input(CLI::App* sub, VolumeInput& in) {
  sub->add_option("volume", in.path, "Labeled volume (NRRD, NIfTI-1, MetaImage, INRIMAGE, gzip of these, or raw)")
      ->required();
  sub->add_option("--raw-dims", in.raw_dims, "Headerless raw: dims nx,ny,nz")->delimiter(',')->expected(3);
  sub->add_option("--raw-spacing", in.raw_spacing, "Headerless raw: spacing sx,sy,sz")->delimiter(',')->expected(3);
  sub->add_option("--raw-type", in.raw_type, "Headerless raw: u8, i8, u16, i16, u32 or i32")->capture_default_str();
  sub->add_flag("--raw-big-endian", in.raw_big_endian, "Headerless raw: samples are big-endian");
}

io::LabelVolume read_volume_input(const VolumeInput& in) {
  if (in.raw_dims.empty()) return io::read_label_volume(in.path);
  io::RawOptions raw;
  raw.dims = {in.raw_dims[0], in.raw_dims[1], in.raw_dims[2]};
  raw.spacing = {in.raw_spacing[0], in.raw_spacing[1], in.raw_spacing[2]};
  raw.type = io::parse_scalar_type(in.raw_type, "--raw-type");
  raw.big_endian = in.raw_big_endian;
  return io::read_label_volume(in.path, &raw);
}

}  // namespace cpmesh::cli
