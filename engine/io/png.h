#pragma once
// PNG writer (8-bit RGBA, no interlace, filter 0, zlib deflate), written atomically. For the mesh preview.
#include <cstdint>
#include <string>
#include <vector>

namespace cpmesh::io {

// rgba: width x height pixels row by row from the top, R in the low byte.
void write_png(const std::string& path, uint32_t width, uint32_t height, const std::vector<uint32_t>& rgba);

}  // namespace cpmesh::io
