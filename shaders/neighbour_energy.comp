#version 450
// Particle energy and its gradient from Verlet neighbour lists (particles::ParticleSystem; seed paper Eq. 1-2): the
// exact tree walk's sum, over the list that tree_walk_lists stored for each particle instead of over the octree's
// leaves. The lists hold every j within SUPPORT min(h_i, h_j) (1 + skin) of where the particles were when they were
// built, so while no particle has drifted too far since (neighbour_drift.comp; the bound is in particle_system.h)
// they hold every j that interacts now. Same pair arithmetic as the walk (pair_energy.glsl). Reference: ref::particle_energy
// (brute force); ref::neighbour_lists for the lists.
// Bindings: 0 particles samplerBuffer (n texels: xyz, w = h); 1 lists uint[n * capacity]; 2 list lengths uint[n] (bit 31: the walk
//           that built them ran out of budget); 3 result vec4[n] (gradient of E_i wrt p_i in xyz, E_i in w); 4 counts
//           uint[n] (pairs evaluated; bit 31 copied from the lengths, or set when a list overflowed its capacity).
// Push: n, capacity. Dispatch: n threads, 64 per workgroup.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "pair_energy.glsl"

layout(local_size_x = 64) in;
layout(binding = 0) uniform samplerBuffer particles;  // texels: lavapipe gathers them, see fields/cp_lookup_gpu.h
layout(std430, binding = 1) readonly buffer Lists { uint lists[]; };
layout(std430, binding = 2) readonly buffer Lengths { uint lengths[]; };
layout(std430, binding = 3) writeonly buffer Result { vec4 result[]; };
layout(std430, binding = 4) writeonly buffer Counts { uint counts[]; };
layout(push_constant) uniform Push { uint n; uint capacity; } pc;

void main() {
  const uint i = flat_group_id() * 64 + gl_LocalInvocationID.x;
  if (i >= pc.n) return;
  const vec4 pi4 = texelFetch(particles, int(i));
  const uint length_flags = lengths[i];
  const uint listed = length_flags & 0x7fffffffu;
  const uint stored = min(listed, pc.capacity);
  float energy = 0.0;
  vec3 grad = vec3(0.0);
  uint pairs = 0;
  for (uint q = 0; q < stored; ++q) {
    const vec4 pj = texelFetch(particles, int(lists[i * pc.capacity + q]));
    const vec3 delta = pi4.xyz - pj.xyz;
    if (add_pair_energy(delta, length(delta), SUPPORT * min(pi4.w, pj.w), energy, grad)) ++pairs;
  }
  result[i] = vec4(grad, energy);
  counts[i] = pairs | (((length_flags & 0x80000000u) != 0u || listed > pc.capacity) ? 0x80000000u : 0u);
}
