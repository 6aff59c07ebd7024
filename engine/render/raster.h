#pragma once
// The input of the preview rasterizer (shaders/raster.comp, shaders/raster_resolve.comp; reference ref::rasterize):
// screen-space vertices and coloured triangles, already lit on the host.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::render {

struct RasterInput {
  uint32_t width = 0, height = 0;
  uint32_t background = 0xffffffffu;  // RGBA8, R in the low byte
  std::vector<glm::vec4> vertices;    // x, y in pixels (y down), z in [0, 1] (nearer is smaller)
  std::vector<glm::uvec4> triangles;  // vertex indices, colour RGBA8
};

struct Image {
  uint32_t width = 0, height = 0;
  std::vector<uint32_t> rgba;  // row by row from the top, RGBA8 (R in the low byte)
};

}  // namespace cpmesh::render
