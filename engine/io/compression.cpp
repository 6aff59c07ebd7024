#include "io/compression.h"

#include <zlib.h>

#include <algorithm>

#include "io/error.h"

namespace cpmesh::io {

bool has_gzip_magic(std::string_view bytes) {
  return bytes.size() >= 2 && uint8_t(bytes[0]) == 0x1f && uint8_t(bytes[1]) == 0x8b;
}

std::string inflate_stream(std::string_view compressed, size_t max_out, const std::string& file,
                           const std::string& field, bool* complete) {
  z_stream zs{};
  if (inflateInit2(&zs, 15 + 32) != Z_OK) fail(file, "zlib initialisation failed");  // 15 + 32: gzip or zlib
  std::string out;
  size_t in_pos = 0;
  int rc = Z_OK;
  bool ended = false;
  while (out.size() < max_out) {
    // zlib counts in uInt: feed and drain in bounded chunks.
    if (zs.avail_in == 0 && in_pos < compressed.size()) {
      const size_t n = std::min<size_t>(compressed.size() - in_pos, 1u << 30);
      zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(compressed.data() + in_pos));
      zs.avail_in = uInt(n);
      in_pos += n;
    }
    const size_t chunk = std::min<size_t>(max_out - out.size(), size_t(1) << 24);
    const size_t before = out.size();
    out.resize(before + chunk);
    zs.next_out = reinterpret_cast<Bytef*>(out.data() + before);
    zs.avail_out = uInt(chunk);
    rc = inflate(&zs, Z_NO_FLUSH);
    out.resize(before + (chunk - zs.avail_out));
    if (rc == Z_STREAM_END) {
      ended = true;
      break;
    }
    if (rc == Z_BUF_ERROR && zs.avail_in == 0 && in_pos >= compressed.size()) break;  // input ran out: truncated
    if (rc != Z_OK && rc != Z_BUF_ERROR) {
      const std::string msg = zs.msg ? zs.msg : "error " + std::to_string(rc);
      inflateEnd(&zs);
      fail(file, "field '" + field + "': corrupt compressed data (zlib: " + msg + ")");
    }
  }
  inflateEnd(&zs);
  if (complete) *complete = ended;
  if (!ended && out.size() < max_out)
    fail(file, "field '" + field + "': compressed data ends early (truncated stream after " +
                   std::to_string(out.size()) + " bytes)");
  return out;
}

namespace {

std::string deflate_with(std::string_view data, int window_bits) {
  z_stream zs{};
  if (deflateInit2(&zs, Z_DEFAULT_COMPRESSION, Z_DEFLATED, window_bits, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    throw Error("zlib: deflate initialisation failed");
  std::string out(deflateBound(&zs, uLong(data.size())) + 64, '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  zs.avail_in = uInt(data.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = uInt(out.size());
  const int rc = deflate(&zs, Z_FINISH);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  if (rc != Z_STREAM_END) throw Error("zlib: deflate failed");
  return out;
}

}  // namespace

std::string gzip_compress(std::string_view data) { return deflate_with(data, 15 + 16); }
std::string zlib_compress(std::string_view data) { return deflate_with(data, 15); }

}  // namespace cpmesh::io
