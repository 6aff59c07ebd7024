#version 450
// Add/delete flags of the particles (particles::ParticleSystem::check_population; seed paper Sec. 6.2, step one):
// a particle whose walk energy is above delete_factor x its feature's ideal is a delete candidate (flag 1), below
// add_factor x ideal an add candidate (flag 2); features with ideal 0 (quadruple points) are never flagged. Counts
// the candidates and, per feature, the particles and the sum of E / ideal in fixed point (x 64, each term capped at
// 16, so a feature of up to 4M particles cannot overflow). Reference: ref::population_flags.
// Bindings: 0 walk result vec4[n] (gradient, E); 1 features uint[n]; 2 ideals float[features];
//           3 flags uint[n] (written); 4 counters uint[2 + 2 features] (delete, add, then per feature sum, count;
//           zeroed by the caller).
// Dispatch: n threads, 64 per workgroup.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer WalkResult { vec4 walk[]; };
layout(std430, binding = 1) readonly buffer Features { uint features[]; };
layout(std430, binding = 2) readonly buffer Ideals { float ideals[]; };
layout(std430, binding = 3) writeonly buffer Flags { uint flags[]; };
layout(std430, binding = 4) buffer Counters { uint counters[]; };
layout(push_constant) uniform Push {
  uint n;
  float delete_factor;
  float add_factor;
} pc;

void main() {
  const uint i = flat_group_id() * 64 + gl_LocalInvocationID.x;
  if (i >= pc.n) return;
  const uint f = features[i];
  const float ideal = ideals[f];
  uint flag = 0u;
  if (ideal > 0.0) {
    const float e = walk[i].w;
    if (e > pc.delete_factor * ideal) flag = 1u;
    else if (e < pc.add_factor * ideal) flag = 2u;
    if (flag != 0u) atomicAdd(counters[flag - 1u], 1u);
    atomicAdd(counters[2u + 2u * f], uint(min(e / ideal, 16.0) * 64.0 + 0.5));
    atomicAdd(counters[3u + 2u * f], 1u);
  }
  flags[i] = flag;
}
