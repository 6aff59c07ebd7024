#pragma once
// INRIMAGE-4 (.inr; .inr.gz is the file gzip-compressed as a whole): a text header padded to a multiple of 256 bytes
// ("#INRIMAGE-4#{" ... "##}\n") followed by the samples.
#include <string>
#include <string_view>

#include "io/volume_layout.h"
#include "io/volume_writer_options.h"

namespace cpmesh::io {

bool is_inrimage(std::string_view head);
VolumeLayout parse_inrimage_header(const std::string& file, std::string_view head);

void write_inrimage(const std::string& path, const LabelVolume& v, const VolumeWriteOptions& o);

}  // namespace cpmesh::io
