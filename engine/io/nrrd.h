#pragma once
// NRRD (teem.sourceforge.net/nrrd/format.html): attached .nrrd and detached .nhdr headers, raw and gzip encodings.
#include <string>
#include <string_view>

#include "io/volume_layout.h"
#include "io/volume_writer_options.h"

namespace cpmesh::io {

bool is_nrrd(std::string_view head);
// `head`: the file's first bytes (inflated when the whole file was gzip-compressed).
VolumeLayout parse_nrrd_header(const std::string& file, std::string_view head);

// A path ending in .nhdr writes a detached header and its data file "<stem>.raw" (".raw.gz" when compressed).
void write_nrrd(const std::string& path, const LabelVolume& v, bool gzip);
void write_nrrd(const std::string& path, const FloatVolume& v, bool gzip);
void write_nrrd(const std::string& path, const LabelVolume& v, const VolumeWriteOptions& o);

}  // namespace cpmesh::io
