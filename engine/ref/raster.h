#pragma once
// Reference of the preview rasterizer (shaders/raster.comp, raster_resolve.comp): the same coverage test, depth
// quantization, tie rule (larger triangle index wins) and float arithmetic, one triangle after the other.
#include "render/raster.h"

namespace cpmesh::ref {

render::Image rasterize(const render::RasterInput& input);

}  // namespace cpmesh::ref
