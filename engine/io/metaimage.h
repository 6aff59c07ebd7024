#pragma once
// MetaImage (ITK): .mha with the data after the header ("ElementDataFile = LOCAL"), .mhd with a separate data file,
// optionally zlib-compressed ("CompressedData = True").
#include <string>
#include <string_view>

#include "io/volume_layout.h"
#include "io/volume_writer_options.h"

namespace cpmesh::io {

bool is_metaimage(std::string_view head);
VolumeLayout parse_metaimage_header(const std::string& file, std::string_view head);

// A path ending in .mhd writes the data to "<stem>.raw" (".zraw" when compressed); .mha keeps it in the file.
void write_metaimage(const std::string& path, const LabelVolume& v, const VolumeWriteOptions& o);

}  // namespace cpmesh::io
