#version 450
// Morton (Z-order) keys of particle positions (the octree's first step, Bedorf et al.'s Bonsai): each coordinate is
// quantised to 21 bits inside the bounding box and the bits are interleaved x, y, z from the least significant end,
// giving a 63-bit key; the payload is the particle index, ready for the 64-bit radix sort.
// Bindings: 0 positions vec4[n] (xyz local coordinates); 1 keys uvec2[n] (low word, high word); 2 indices uint[n].
// Push: box_min (xyz), scale (xyz: 2^21 / box extent), n. Positions outside the box are clamped to its faces.
// Dispatch: n threads, 256 per workgroup. Reference: ref::morton_codes (same float32 arithmetic, bit-exact).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = 1) writeonly buffer Keys { uvec2 keys[]; };
layout(std430, binding = 2) writeonly buffer Indices { uint indices[]; };
layout(push_constant) uniform Push {
  vec4 box_min;
  vec4 scale;
  uint n;
} pc;

// Spreads the low 21 bits of v so that bit i lands at bit 3i (as a 64-bit value in two words).
uvec2 spread21(uint v) {
  uvec2 r = uvec2(0);
  for (uint i = 0; i < 21; ++i) {
    const uint bit = (v >> i) & 1u;
    const uint pos = 3 * i;
    if (pos < 32) r.x |= bit << pos; else r.y |= bit << (pos - 32);
  }
  return r;
}

void main() {
  const uint i = flat_group_id() * 256 + gl_LocalInvocationID.x;
  if (i >= pc.n) return;
  const vec3 q = floor((positions[i].xyz - pc.box_min.xyz) * pc.scale.xyz);
  const uvec3 c = uvec3(clamp(q, vec3(0.0), vec3(2097151.0)));
  const uvec2 x = spread21(c.x), y = spread21(c.y), z = spread21(c.z);
  // Interleave: x at bit 3i, y at 3i + 1, z at 3i + 2.
  keys[i] = uvec2(x.x | (y.x << 1) | (z.x << 2), x.y | (y.y << 1) | (z.y << 2) | (y.x >> 31) | (z.x >> 30));
  indices[i] = i;
}
