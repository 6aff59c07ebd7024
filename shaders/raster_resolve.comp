#version 450
// Preview colours (render::render_preview; reference ref::rasterize): every pixel takes the colour of the triangle
// the id pass left there, or the background. Bindings: 0 triangles uvec4[] (a, b, c, colour RGBA8); 1 ids
// uint[width * height]; 2 image uint[width * height] (RGBA8, written).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Triangles { uvec4 triangles[]; };
layout(std430, binding = 1) readonly buffer Ids { uint ids[]; };
layout(std430, binding = 2) writeonly buffer Image { uint image[]; };
layout(push_constant) uniform Push {
  uint pixels;
  uint background;
} pc;

void main() {
  const uint p = flat_group_id() * 64 + gl_LocalInvocationID.x;
  if (p >= pc.pixels) return;
  const uint id = ids[p];
  image[p] = id == 0u ? pc.background : triangles[id - 1u].w;
}
