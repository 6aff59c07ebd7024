#pragma once
// zlib and gzip streams (NRRD gzip encoding, MetaImage CompressedData, .nii.gz, .inr.gz).
#include <cstddef>
#include <string>
#include <string_view>

namespace cpmesh::io {

bool has_gzip_magic(std::string_view bytes);

// Inflates a gzip or zlib stream (detected from its header). Stops with the bytes produced so far once `max_out`
// bytes exist, so a corrupt or hostile stream never allocates more than the caller expects; `complete` (when given)
// tells whether the stream ended there. Corrupt data throws Error naming `file` and `field`.
std::string inflate_stream(std::string_view compressed, size_t max_out, const std::string& file,
                           const std::string& field, bool* complete = nullptr);

std::string gzip_compress(std::string_view data);
std::string zlib_compress(std::string_view data);

}  // namespace cpmesh::io
