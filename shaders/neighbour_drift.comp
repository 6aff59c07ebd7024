#version 450
// How far the particles have drifted since their Verlet neighbour lists were built (particles::ParticleSystem): the
// largest |p_i - a_i| / h(a_i) over all particles, a_i the position at the build. Non-negative floats order like
// their bit patterns, so one atomicMax on the bits gives the maximum, independent of the order of the threads.
// Bindings: 0 particles vec4[n] (xyz, w = h); 1 anchors vec4[n] (the same at the build); 2 drift uint[1] (float bits,
//           zeroed by the caller). Push: n. Dispatch: n threads, 64 per workgroup. Reference: ref::neighbour_drift.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Particles { vec4 particles[]; };
layout(std430, binding = 1) readonly buffer Anchors { vec4 anchors[]; };
layout(std430, binding = 2) buffer Drift { uint drift[]; };
layout(push_constant) uniform Push { uint n; } pc;

void main() {
  const uint i = flat_group_id() * 64 + gl_LocalInvocationID.x;
  if (i >= pc.n) return;
  const vec4 a = anchors[i];
  const float d = length(particles[i].xyz - a.xyz) / a.w;
  // A NaN or an infinity (h = 0) counts as the largest drift: the lists are rebuilt.
  atomicMax(drift[0], finite_bits(d) ? floatBitsToUint(d) : 0x7f800000u);
}
