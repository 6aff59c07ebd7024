#version 450
// Software rasterizer for the preview (render::render_preview; reference ref::rasterize), one thread per triangle,
// two passes over the same coverage test:
//   depth pass (default): atomicMin of the quantized depth at every covered pixel centre;
//   id pass (-DID_PASS): where the pixel's depth equals the triangle's, atomicMax of triangle index + 1 (ties go to
//   the larger index, in both the shader and the reference).
// Coverage: pixel centre (x + 0.5, y + 0.5) inside or on the triangle (edge functions of the triangle's sign).
// Each thread visits at most kMaxPixels of its bounding box (row by row), far below lavapipe's loop limit; larger
// triangles are drawn in part (a preview of a mesh has small triangles).
// Bindings: 0 screen vertices vec4[] (x, y in pixels, z in [0, 1] nearer smaller); 1 triangles uvec4[] (a, b, c,
// colour); 2 depth uint[width * height]; 3 ids uint[width * height].
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Vertices { vec4 vertices[]; };
layout(std430, binding = 1) readonly buffer Triangles { uvec4 triangles[]; };
layout(std430, binding = 2) buffer Depth { uint depth[]; };
layout(std430, binding = 3) buffer Ids { uint ids[]; };
layout(push_constant) uniform Push {
  uint width;
  uint height;
  uint count;
} pc;

const uint kMaxPixels = 16384u;

float edge(vec2 a, vec2 b, vec2 p) { return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x); }

void main() {
  const uint t = flat_group_id() * 64 + gl_LocalInvocationID.x;
  if (t >= pc.count) return;
  const uvec4 tri = triangles[t];
  const vec3 a = vertices[tri.x].xyz, b = vertices[tri.y].xyz, c = vertices[tri.z].xyz;
  const float area = edge(a.xy, b.xy, c.xy);
  if (area == 0.0) return;
  const float s = area > 0.0 ? 1.0 : -1.0;
  const int x0 = max(int(floor(min(a.x, min(b.x, c.x)))), 0);
  const int x1 = min(int(ceil(max(a.x, max(b.x, c.x)))), int(pc.width) - 1);
  const int y0 = max(int(floor(min(a.y, min(b.y, c.y)))), 0);
  const int y1 = min(int(ceil(max(a.y, max(b.y, c.y)))), int(pc.height) - 1);
  if (x1 < x0 || y1 < y0) return;
  const uint w = uint(x1 - x0 + 1);
  const uint pixels = min(w * uint(y1 - y0 + 1), kMaxPixels);
  for (uint i = 0u; i < pixels; ++i) {
    const int x = x0 + int(i % w), y = y0 + int(i / w);
    const vec2 p = vec2(float(x) + 0.5, float(y) + 0.5);
    const float w0 = s * edge(b.xy, c.xy, p), w1 = s * edge(c.xy, a.xy, p), w2 = s * edge(a.xy, b.xy, p);
    if (w0 < 0.0 || w1 < 0.0 || w2 < 0.0) continue;
    const float z = (w0 * a.z + w1 * b.z + w2 * c.z) / (s * area);
    const uint q = uint(clamp(z, 0.0, 1.0) * 16777215.0);
    const uint pixel = uint(y) * pc.width + uint(x);
#ifdef ID_PASS
    if (depth[pixel] == q) atomicMax(ids[pixel], t + 1u);
#else
    atomicMin(depth[pixel], q);
#endif
  }
}
