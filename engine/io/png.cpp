#include "io/png.h"

#include <stdexcept>

#include <zlib.h>

#include "io/atomic_file.h"

namespace cpmesh::io {

namespace {

void put32(std::string& s, uint32_t v) {
  for (int k = 3; k >= 0; --k) s.push_back(char((v >> (8 * k)) & 0xff));
}

void chunk(std::string& out, const char* type, const std::string& data) {
  put32(out, uint32_t(data.size()));
  std::string body(type, 4);
  body += data;
  out += body;
  put32(out, uint32_t(crc32(0L, reinterpret_cast<const Bytef*>(body.data()), uInt(body.size()))));
}

}  // namespace

void write_png(const std::string& path, uint32_t width, uint32_t height, const std::vector<uint32_t>& rgba) {
  if (width == 0 || height == 0 || rgba.size() != size_t(width) * height)
    throw std::invalid_argument(path + ": PNG of " + std::to_string(width) + " x " + std::to_string(height) +
                                " pixels needs that many values, got " + std::to_string(rgba.size()));
  std::string raw;
  raw.reserve(size_t(height) * (1 + 4 * size_t(width)));
  for (uint32_t y = 0; y < height; ++y) {
    raw.push_back('\0');  // filter: none
    for (uint32_t x = 0; x < width; ++x) {
      const uint32_t p = rgba[size_t(y) * width + x];
      for (int k = 0; k < 4; ++k) raw.push_back(char((p >> (8 * k)) & 0xff));
    }
  }
  uLongf packed_size = compressBound(uLong(raw.size()));
  std::string packed(packed_size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(packed.data()), &packed_size, reinterpret_cast<const Bytef*>(raw.data()),
                uLong(raw.size()), 6) != Z_OK)
    throw std::runtime_error(path + ": PNG compression failed");
  packed.resize(packed_size);
  std::string header;
  put32(header, width);
  put32(header, height);
  header += std::string("\x08\x06\x00\x00\x00", 5);  // 8 bits, RGBA, deflate, filter 0, no interlace
  std::string png("\x89PNG\r\n\x1a\n", 8);
  chunk(png, "IHDR", header);
  chunk(png, "IDAT", packed);
  chunk(png, "IEND", "");
  write_atomically(path, [&](std::ostream& out) { out.write(png.data(), std::streamsize(png.size())); });
}

}  // namespace cpmesh::io
