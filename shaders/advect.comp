#version 450
// One advection step of every particle (particles::Advection; seed paper Sec. 5): move against the energy gradient,
// scaled by the particle's sizing (step = -alpha h^2 grad E_i, at most max_move h long), then put the particle back on
// its feature with the closest point lookup. Projecting onto the feature afterwards removes the step's normal part
// (interfaces) or all but its tangential part (triple curves) to first order: the closest point method's tangent
// projection. Quadruple points never move. A particle whose moved position leaves its feature's band stays put and
// is counted in `lost`, as is one whose lookup gives no finite point with a positive h. The sizing at the new
// position (the lookup's w) becomes the particle's h.
// Bindings: 0-6 cp_keys, cp_tiles, cp_cells, cp_fine0..3 (texel buffers: fields::GpuEmbedding); 7 particles vec4[n] (xyz, h;
//           updated); 8 features uint[n]; 9 feature_kinds uint[] (0 point, 1 curve, 2 interface); 10 walk result
//           vec4[n] (gradient, E); 11 energy float[n] (E_i copied for the reduction); 12 lost uint[1] (atomic counter).
// Push: embedding geometry, n, alpha, max_move. Dispatch: n threads, 64 per workgroup. Reference: ref::advect.
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
layout(std430, binding = 7) buffer Particles { vec4 particles[]; };
layout(std430, binding = 8) readonly buffer Features { uint features[]; };
layout(std430, binding = 9) readonly buffer FeatureKinds { uint feature_kinds[]; };
layout(std430, binding = 10) readonly buffer WalkResult { vec4 walk[]; };
layout(std430, binding = 11) writeonly buffer Energy { float energy[]; };
layout(std430, binding = 12) buffer Lost { uint lost[]; };
layout(push_constant) uniform Push {
  ivec4 dims_sub;
  vec4 spacing;
  uint table_mask;
  uint chunk_blocks;
  uint n;
  float alpha;
  float max_move;
} pc;

#define CP_DIMS pc.dims_sub.xyz
#define CP_SPACING pc.spacing.xyz
#define CP_MASK pc.table_mask
#define CP_CHUNK_BLOCKS pc.chunk_blocks
#include "cp_lookup.glsl"

void main() {
  const uint i = flat_group_id() * 64 + gl_LocalInvocationID.x;
  if (i >= pc.n) return;
  const vec4 w = walk[i];
  energy[i] = w.w;
  const uint feature = features[i];
  if (feature_kinds[feature] == 0u) return;  // quadruple points are fixed
  const vec4 p = particles[i];
  vec3 step = -pc.alpha * p.w * p.w * w.xyz;
  const float len = length(step), limit = pc.max_move * p.w;
  if (len > limit) step *= limit / len;
  bool valid;
  const vec4 cp = cp_lookup(p.xyz + step, feature, valid);
  // A lookup that gives no finite point with a positive h counts as lost too: the particle keeps its place rather
  // than carry a NaN into the tree (ref::advect).
  if (!valid || !finite_bits(cp) || cp.w <= 0.0) {
    atomicAdd(lost[0], 1u);
    return;
  }
  particles[i] = vec4(cp.xyz, cp.w);
}
