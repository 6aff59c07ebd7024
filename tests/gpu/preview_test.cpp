// The preview rasterizer (shaders/raster.comp, raster_resolve.comp) against ref::rasterize, and the PNG writer.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <random>

#include <zlib.h>

#include "gpu_fixture.h"
#include "scratch_dir.h"
#include "io/png.h"
#include "ref/raster.h"
#include "render/preview.h"

using namespace cpmesh;
using cpmesh::test::GpuFixture;

TEST_CASE_FIXTURE(GpuFixture, "preview rasterizer: the device image equals the reference") {
  render::RasterInput in;
  in.width = 301;
  in.height = 173;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> x(-20.0f, 320.0f), y(-20.0f, 190.0f), z(0.0f, 1.0f), d(-25.0f, 25.0f);
  for (int t = 0; t < 3000; ++t) {  // overlapping triangles of every orientation, some off the image
    const glm::vec2 c(x(rng), y(rng));
    const uint32_t base = uint32_t(in.vertices.size());
    for (int k = 0; k < 3; ++k) in.vertices.push_back(glm::vec4(c.x + d(rng), c.y + d(rng), z(rng), 0.0f));
    in.triangles.push_back(glm::uvec4(base, base + 1, base + 2, 0xff000000u | uint32_t(rng() & 0xffffff)));
  }
  in.triangles.push_back(glm::uvec4(0, 0, 1, 0xff0000ffu));  // degenerate: drawn nowhere
  const auto want = ref::rasterize(in);
  const auto got = render::rasterize(ctx, in);
  REQUIRE(got.rgba.size() == want.rgba.size());
  size_t differ = 0, background = 0;
  for (size_t p = 0; p < got.rgba.size(); ++p) {
    differ += got.rgba[p] != want.rgba[p];
    background += want.rgba[p] == in.background;
  }
  MESSAGE(differ << " of " << got.rgba.size() << " pixels differ; " << background << " background");
  CHECK(differ <= got.rgba.size() / 1000);  // float rounding at shared edges and equal depths only
  CHECK(background < got.rgba.size() / 2);
}

TEST_CASE("PNG writer: signature, header and pixels read back") {
  const uint32_t w = 7, h = 5;
  std::vector<uint32_t> rgba(w * h);
  for (uint32_t i = 0; i < rgba.size(); ++i) rgba[i] = 0xff000000u | (i * 2654435761u & 0xffffff);
  const auto path = test::scratch_dir("png") / "test.png";
  io::write_png(path.string(), w, h, rgba);
  std::ifstream f(path, std::ios::binary);
  const std::string png((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  REQUIRE(png.size() > 8 + 25 + 12);
  CHECK(png.substr(0, 8) == std::string("\x89PNG\r\n\x1a\n", 8));
  CHECK(png.substr(12, 4) == "IHDR");
  auto be32 = [&](size_t at) {
    return uint32_t(uint8_t(png[at])) << 24 | uint32_t(uint8_t(png[at + 1])) << 16 | uint32_t(uint8_t(png[at + 2])) << 8 | uint8_t(png[at + 3]);
  };
  CHECK(be32(16) == w);
  CHECK(be32(20) == h);
  const size_t idat = png.find("IDAT");
  REQUIRE(idat != std::string::npos);
  const uint32_t len = be32(idat - 4);
  std::string raw(h * (1 + 4 * w), '\0');
  uLongf raw_len = uLongf(raw.size());
  REQUIRE(uncompress(reinterpret_cast<Bytef*>(raw.data()), &raw_len, reinterpret_cast<const Bytef*>(png.data() + idat + 4), len) == Z_OK);
  CHECK(raw_len == raw.size());
  bool same = true;
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x)
      for (int k = 0; k < 4; ++k)
        same = same && uint8_t(raw[y * (1 + 4 * w) + 1 + 4 * x + size_t(k)]) == ((rgba[y * w + x] >> (8 * k)) & 0xff);
  CHECK(same);
  std::filesystem::remove(path);
  CHECK_THROWS_AS(io::write_png(path.string(), 3, 3, rgba), std::invalid_argument);
}
