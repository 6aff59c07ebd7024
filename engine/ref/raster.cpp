#include "ref/raster.h"

#include <algorithm>
#include <cmath>

namespace cpmesh::ref {

namespace {
float edge(const glm::vec2& a, const glm::vec2& b, const glm::vec2& p) {
  return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
}
}  // namespace

render::Image rasterize(const render::RasterInput& in) {
  const size_t n = size_t(in.width) * in.height;
  std::vector<uint32_t> depth(n, 0xffffffffu), ids(n, 0);
  constexpr uint32_t kMaxPixels = 16384;
  for (int pass = 0; pass < 2; ++pass)
    for (uint32_t t = 0; t < in.triangles.size(); ++t) {
      const glm::uvec4 tri = in.triangles[t];
      const glm::vec3 a(in.vertices[tri.x]), b(in.vertices[tri.y]), c(in.vertices[tri.z]);
      const float area = edge(a, b, c);
      if (area == 0.0f) continue;
      const float s = area > 0.0f ? 1.0f : -1.0f;
      const int x0 = std::max(int(std::floor(std::min({a.x, b.x, c.x}))), 0);
      const int x1 = std::min(int(std::ceil(std::max({a.x, b.x, c.x}))), int(in.width) - 1);
      const int y0 = std::max(int(std::floor(std::min({a.y, b.y, c.y}))), 0);
      const int y1 = std::min(int(std::ceil(std::max({a.y, b.y, c.y}))), int(in.height) - 1);
      if (x1 < x0 || y1 < y0) continue;
      const uint32_t w = uint32_t(x1 - x0 + 1);
      const uint32_t pixels = std::min(w * uint32_t(y1 - y0 + 1), kMaxPixels);
      for (uint32_t i = 0; i < pixels; ++i) {
        const int x = x0 + int(i % w), y = y0 + int(i / w);
        const glm::vec2 p(float(x) + 0.5f, float(y) + 0.5f);
        const float w0 = s * edge(b, c, p), w1 = s * edge(c, a, p), w2 = s * edge(a, b, p);
        if (w0 < 0.0f || w1 < 0.0f || w2 < 0.0f) continue;
        const float z = (w0 * a.z + w1 * b.z + w2 * c.z) / (s * area);
        const uint32_t q = uint32_t(std::clamp(z, 0.0f, 1.0f) * 16777215.0f);
        const size_t pixel = size_t(y) * in.width + size_t(x);
        if (pass == 0) depth[pixel] = std::min(depth[pixel], q);
        else if (depth[pixel] == q) ids[pixel] = std::max(ids[pixel], t + 1);
      }
    }
  render::Image out{in.width, in.height, std::vector<uint32_t>(n)};
  for (size_t p = 0; p < n; ++p) out.rgba[p] = ids[p] == 0 ? in.background : in.triangles[ids[p] - 1].w;
  return out;
}

}  // namespace cpmesh::ref
