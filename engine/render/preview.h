#pragma once
// The preview image of `cpmesh mesh --preview` (issue 8): the interface meshes drawn from one oblique view (left half)
// and the same view cut away at the centre (right half: triangles on the viewer's side of the plane through the
// centre facing the viewer are dropped, so inner interfaces show), coloured by material pair, lit by a headlight.
// Drawn offscreen on the Vulkan device by a compute rasterizer (shaders/raster.comp), so it needs no display and
// no graphics queue; ref::rasterize is its reference. Written as PNG (io/png.h).
#include "gpu/context.h"
#include "io/mesh.h"
#include "render/raster.h"

namespace cpmesh::render {

// Projects and lights the triangles of both views (host side, shared by the device path and the reference).
RasterInput preview_scene(const io::TriangleMesh& surfaces, uint32_t width, uint32_t height);
// RGBA8 colour of a material pair, before lighting.
glm::vec3 pair_colour(uint16_t a, uint16_t b);

Image rasterize(gpu::Context& ctx, const RasterInput& input);

}  // namespace cpmesh::render
