#include "render/preview.h"

#include <algorithm>
#include <cmath>

#include "cpmesh/shaders.h"
#include "gpu/buffer.h"
#include "gpu/kernel.h"
#include "gpu/sequence.h"

namespace cpmesh::render {

glm::vec3 pair_colour(uint16_t a, uint16_t b) {
  // Hues spread by the golden angle over a hash of the pair; fixed saturation and value.
  const uint32_t h = (uint32_t(a) * 73856093u) ^ (uint32_t(b) * 19349663u);
  const double hue = std::fmod(double(h % 1000u) * 0.618033988749895, 1.0) * 6.0;
  const double s = 0.65, v = 0.95, c = v * s, x = c * (1 - std::fabs(std::fmod(hue, 2.0) - 1)), m = v - c;
  glm::dvec3 rgb = hue < 1 ? glm::dvec3(c, x, 0) : hue < 2 ? glm::dvec3(x, c, 0) : hue < 3 ? glm::dvec3(0, c, x)
                 : hue < 4 ? glm::dvec3(0, x, c) : hue < 5 ? glm::dvec3(x, 0, c) : glm::dvec3(c, 0, x);
  return glm::vec3(rgb + m);
}

RasterInput preview_scene(const io::TriangleMesh& S, uint32_t width, uint32_t height) {
  RasterInput in;
  in.width = width;
  in.height = height;
  in.background = 0xff000000u | (250u << 16) | (246u << 8) | 242u;
  if (S.vertices.empty()) return in;
  glm::dvec3 lo(1e300), hi(-1e300);
  for (const auto& v : S.vertices) {
    lo = glm::min(lo, glm::dvec3(v[0], v[1], v[2]));
    hi = glm::max(hi, glm::dvec3(v[0], v[1], v[2]));
  }
  const glm::dvec3 centre = 0.5 * (lo + hi);
  double radius = 1e-12;  // of the bounding sphere about the box centre: the mesh fills the view's height
  for (const auto& v : S.vertices) radius = std::max(radius, glm::length(glm::dvec3(v[0], v[1], v[2]) - centre));
  const glm::dvec3 eye = glm::normalize(glm::dvec3(1.0, -1.3, 0.9));  // from the centre towards the viewer
  const glm::dvec3 forward = -eye, right = glm::normalize(glm::cross(forward, glm::dvec3(0, 0, 1)));
  const glm::dvec3 up = glm::cross(right, forward);
  const glm::dvec3 light = glm::normalize(eye + 0.4 * up);
  const uint32_t view_w = width / 2;
  const double scale = 0.5 * std::min(double(view_w), double(height)) * 0.92 / radius;
  for (int view = 0; view < 2; ++view) {
    const uint32_t base = uint32_t(in.vertices.size());
    const double ox = view * double(view_w) + 0.5 * view_w, oy = 0.5 * height;
    for (const auto& v : S.vertices) {
      const glm::dvec3 d = glm::dvec3(v[0], v[1], v[2]) - centre;
      in.vertices.push_back(glm::vec4(float(ox + scale * glm::dot(d, right)), float(oy - scale * glm::dot(d, up)),
                                      float(0.5 + 0.5 * glm::dot(d, forward) / radius), 0.0f));
    }
    for (size_t t = 0; t < S.triangles.size(); ++t) {
      const auto& tri = S.triangles[t];
      const glm::dvec3 a(S.vertices[tri[0]][0], S.vertices[tri[0]][1], S.vertices[tri[0]][2]);
      const glm::dvec3 b(S.vertices[tri[1]][0], S.vertices[tri[1]][1], S.vertices[tri[1]][2]);
      const glm::dvec3 c(S.vertices[tri[2]][0], S.vertices[tri[2]][1], S.vertices[tri[2]][2]);
      if (view == 1 && glm::dot((a + b + c) / 3.0 - centre, eye) > 0) continue;  // the cut-away half
      const glm::dvec3 n = glm::cross(b - a, c - a);
      const double len = glm::length(n);
      const double shade = 0.3 + 0.7 * (len > 0 ? std::fabs(glm::dot(n / len, light)) : 0.0);
      const auto pr = t < S.triangle_pair.size() ? S.triangle_pair[t] : std::array<uint16_t, 2>{0, 0};
      const glm::vec3 rgb = pair_colour(pr[0], pr[1]) * float(shade);
      const uint32_t colour = 0xff000000u | (uint32_t(std::lround(std::clamp(rgb.b, 0.0f, 1.0f) * 255)) << 16) |
                              (uint32_t(std::lround(std::clamp(rgb.g, 0.0f, 1.0f) * 255)) << 8) |
                              uint32_t(std::lround(std::clamp(rgb.r, 0.0f, 1.0f) * 255));
      in.triangles.push_back(glm::uvec4(base + tri[0], base + tri[1], base + tri[2], colour));
    }
  }
  return in;
}

Image rasterize(gpu::Context& ctx, const RasterInput& in) {
  const size_t pixels = size_t(in.width) * in.height;
  Image out{in.width, in.height, {}};
  if (pixels == 0) return out;
  if (in.triangles.empty()) {
    out.rgba.assign(pixels, in.background);
    return out;
  }
  gpu::Kernel depth_pass(ctx, shaders::raster_depth), id_pass(ctx, shaders::raster_ids), resolve(ctx, shaders::raster_resolve);
  gpu::Buffer<glm::vec4> vertices(ctx, in.vertices, "preview vertices");
  gpu::Buffer<glm::uvec4> triangles(ctx, in.triangles, "preview triangles");
  gpu::Buffer<uint32_t> depth(ctx, pixels, "preview depth"), ids(ctx, pixels, "preview ids");
  gpu::Buffer<uint32_t> image(ctx, pixels, "preview image", gpu::MemoryUse::readback);
  const struct {
    uint32_t width, height, count;
  } raster{in.width, in.height, uint32_t(in.triangles.size())};
  const struct {
    uint32_t pixels, background;
  } res{uint32_t(pixels), in.background};
  gpu::Sequence(ctx)
      .fill(depth, 0xffffffffu)
      .fill(ids, 0u)
      .barrier()
      .dispatch(depth_pass, {vertices, triangles, depth, ids}, raster, in.triangles.size())
      .barrier()
      .dispatch(id_pass, {vertices, triangles, depth, ids}, raster, in.triangles.size())
      .barrier()
      .dispatch(resolve, {triangles, ids, image}, res, pixels)
      .submit_and_wait();
  out.rgba = image.download();
  return out;
}

}  // namespace cpmesh::render
