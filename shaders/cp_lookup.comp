#version 450
// Closest point lookup for a batch of points (fields::CpLookup): WENO4 interpolation on the closest point embedding,
// no iterative search. Each query is a point in local coordinates (xyz) and its feature (w, as uint bits).
// Bindings: 0-2 cp_keys, cp_tiles, cp_cells usamplerBuffer (fields::EmbeddingTiles); 3-6 cp_fine0..3
//           samplerBuffer (the fine points in four chunks of chunk_blocks blocks); 7 queries vec4[n]; 8 results
//           vec4[n] (closest point xyz, sizing w); 9 valid uint[n] (1, or 0 when the point left its feature's band).
// Push: dims + sub, spacing, n, table mask, chunk_blocks. Dispatch: n threads, 64 per workgroup.
// Reference: ref::cp_lookup.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = 64) in;
layout(binding = 0) uniform usamplerBuffer cp_keys;   // two keys per texel
layout(binding = 1) uniform usamplerBuffer cp_tiles;  // four records per texel
layout(binding = 2) uniform usamplerBuffer cp_cells;  // four cells per texel
layout(binding = 3) uniform samplerBuffer cp_fine0;
layout(binding = 4) uniform samplerBuffer cp_fine1;
layout(binding = 5) uniform samplerBuffer cp_fine2;
layout(binding = 6) uniform samplerBuffer cp_fine3;
layout(std430, binding = 7) readonly buffer Queries { vec4 queries[]; };
layout(std430, binding = 8) writeonly buffer Results { vec4 results[]; };
layout(std430, binding = 9) writeonly buffer Valid { uint valid_out[]; };
layout(push_constant) uniform Push {
  ivec4 dims_sub;  // grid dims (w: sub, read as the specialization constant CP_SUB instead)
  vec4 spacing;    // xyz
  uint n;
  uint table_mask;
  uint chunk_blocks;
} pc;

#define CP_DIMS pc.dims_sub.xyz
#define CP_SPACING pc.spacing.xyz
#define CP_MASK pc.table_mask
#define CP_CHUNK_BLOCKS pc.chunk_blocks
#include "cp_lookup.glsl"

void main() {
  const uint i = flat_group_id() * 64 + gl_LocalInvocationID.x;
  if (i >= pc.n) return;
  const vec4 q = queries[i];
  bool valid;
  results[i] = cp_lookup(q.xyz, floatBitsToUint(q.w), valid);
  valid_out[i] = valid ? 1u : 0u;
}
