#version 450
// Puts the particles in Morton order after the sort (particles::ParticleSystem): slot q takes the position, feature,
// material mask and original id of particle order[q], and order[q] becomes q. The moments, the tree walk and the
// advection that follow then read neighbouring particles from neighbouring slots, and the advection's closest point
// lookups of neighbouring threads hit neighbouring embedding cells (random order read 0.37 M lookups/s on lavapipe,
// sorted 0.54-0.60; issue 9).
// Bindings: 0 order uint[n] (read, then the identity); 1-4 particles vec4[n], features uint[n], ids uint[n], masks
//           uvec4[n] (in); 5-8 the same (out, permuted).
// Push: n. Dispatch: n threads, 256 per workgroup. Each thread reads and writes only its own order[q]: no race.
// Reference: ref::particle_permute.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = 256) in;
layout(std430, binding = 0) buffer Order { uint order[]; };
layout(std430, binding = 1) readonly buffer ParticlesIn { vec4 particles_in[]; };
layout(std430, binding = 2) readonly buffer FeaturesIn { uint features_in[]; };
layout(std430, binding = 3) readonly buffer IdsIn { uint ids_in[]; };
layout(std430, binding = 4) readonly buffer MasksIn { uvec4 masks_in[]; };
layout(std430, binding = 5) writeonly buffer ParticlesOut { vec4 particles_out[]; };
layout(std430, binding = 6) writeonly buffer FeaturesOut { uint features_out[]; };
layout(std430, binding = 7) writeonly buffer IdsOut { uint ids_out[]; };
layout(std430, binding = 8) writeonly buffer MasksOut { uvec4 masks_out[]; };
layout(push_constant) uniform Push { uint n; } pc;

void main() {
  const uint q = flat_group_id() * 256 + gl_LocalInvocationID.x;
  if (q >= pc.n) return;
  const uint i = order[q];
  particles_out[q] = particles_in[i];
  features_out[q] = features_in[i];
  ids_out[q] = ids_in[i];
  masks_out[q] = masks_in[i];
  order[q] = q;
}
