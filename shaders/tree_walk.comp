#version 450
// Particle energy and its gradient by an exact tree walk (octree::TreeWalk; seed paper Eq. 1-2, DESIGN.md):
//   d_ij = |p_i - p_j| / (2 cos(pi/6) min(h_i, h_j)),  E_ij = cot(d pi/2) + d pi/2 - pi/2 for d <= 1, else 0.
// Particle i feels particle j when j lies on i's feature or on a lower-dimensional feature bounding it: the
// materials of j's feature include those of i's (fields::MaterialSet: a 64-bit mask, and with EXACT_SETS four 16-bit
// material slots; material_set.glsl). Nodes whose box is farther than 2 cos(pi/6) h_i are pruned: with the energy's
// compact support that is exact (theta = 0). With theta > 0 (the paper's Barnes-Hut mode) a node that does not hold
// the walker, is seen under size / distance < theta and whose particles all interact with the walker (the
// intersection of their material sets includes the walker's) counts as its particles lumped at their centre of mass
// with the node's smallest h.
// Bindings: 0 nodes usamplerBuffer (uvec4 texels); 1-4 node moments samplerBuffer (box min + min h, box max,
//           centre + count) and usamplerBuffer (the intersection of the node's material sets); 5 order uint[n];
//           6 particles samplerBuffer (xyz, w = h); 7 masks usamplerBuffer (per particle: its feature's material
//           set); 8 result vec4[n] (gradient of E_i wrt p_i in xyz, E_i in w); 9 counts uint[n] (pairs evaluated;
//           bit 31 set when the work budget ran out); 10 visits uint[n] (nodes visited).
// The masks are per particle, not per feature (features[j], then feature_masks[that]), so the leaf scans read each
// candidate's mask as one texel gathered for all lanes: on lavapipe (128^3 wedge ball, 13 k particles, five runs
// alternating) a walk took 12.8-17.9 ms instead of 17.3-20.5, a list walk 19.2-23.2 instead of 24.8-30.3 (issue 9).
// Compiled three times: tree_walk (exact; theta unused), tree_walk_bh (-DBARNES_HUT, theta > 0): on lavapipe a branch
// on a push constant still runs its body under a mask, and the lumping test cost the exact walk 5-10%; and
// tree_walk_lists (-DNEIGHBOUR_LIST, octree::TreeWalk::record_lists): instead of the energy, each particle's Verlet
// neighbour list, the particles j with (j's feature bounds i's) and |p_i - p_j| < SUPPORT min(h_i, h_j) (1 + skin)
// (the pairs' support widened by the skin; the walk prunes by SUPPORT h_i (1 + skin)), in walk order, at most
// `capacity` stored from lists[i * capacity]; then binding 8 is the lists, 9 their full lengths (bit 31: budget),
// and 11 a uint that gets the longest length (atomicMax), so the caller can grow the capacity.
// Push: walkers (<= n), theta, skin, capacity. Dispatch: walkers threads in Morton order (thread k handles particle
// order[k]), 64 per workgroup.
// Loops: one shared budget of WORK_BUDGET iterations (node visits + pairs), far below lavapipe's 65k limit; running
// out is reported, never silent. Reference: ref::particle_energy (brute force).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "material_set.glsl"
#include "pair_energy.glsl"

layout(local_size_x = 64) in;
// The vec4 data every walker fetches from scattered places are texel buffers: lavapipe gathers a texel for all lanes
// at once, where it loads a storage buffer lane by lane and component by component (fields/cp_lookup_gpu.h).
layout(binding = 0) uniform usamplerBuffer nodes;
layout(binding = 1) uniform samplerBuffer m_lo;
layout(binding = 2) uniform samplerBuffer m_hi;
layout(binding = 3) uniform samplerBuffer m_com;
layout(binding = 4) uniform usamplerBuffer m_mask;  // the mask's bits, read as integers
layout(std430, binding = 5) readonly buffer Order { uint order[]; };
layout(binding = 6) uniform samplerBuffer particles;
layout(binding = 7) uniform usamplerBuffer masks;
#ifdef NEIGHBOUR_LIST
layout(std430, binding = 8) writeonly buffer Lists { uint lists[]; };
layout(std430, binding = 11) buffer Longest { uint longest[]; };
#else
layout(std430, binding = 8) writeonly buffer Result { vec4 result[]; };
#endif
layout(std430, binding = 9) writeonly buffer Counts { uint counts[]; };
layout(std430, binding = 10) writeonly buffer Visits { uint visits[]; };
layout(push_constant) uniform Push { uint walkers; float theta; float skin; uint capacity; } pc;

const uint WORK_BUDGET = 60000;
const uint STACK = 160;                    // depth 22 x 7 pending siblings + 1

void main() {
  const uint k = flat_group_id() * 64 + gl_LocalInvocationID.x;
  if (k >= pc.walkers) return;
  const uint i = order[k];
  const vec4 pi4 = texelFetch(particles, int(i));
  const vec3 p = pi4.xyz;
  const float hi_ = pi4.w;
  const uvec4 mine = texelFetch(masks, int(i));  // i's material set: mask64, slots
  const uvec4 mine2 = ms_slots2(mine.zw);
#ifdef NEIGHBOUR_LIST
  const float cutoff = SUPPORT * hi_ * (1.0 + pc.skin);
  const uint list_start = i * pc.capacity;
#else
  const float cutoff = SUPPORT * hi_;
#endif
  uint stack[STACK];
  uint sp = 0;
  stack[sp++] = 0;
  uint work = 0, pairs = 0, visited = 0;
  float energy = 0.0;
  vec3 grad = vec3(0.0);
  while (sp > 0 && work < WORK_BUDGET) {
    const uint id = stack[--sp];
    ++work;
    ++visited;
    const vec3 lo = texelFetch(m_lo, int(id)).xyz, up = texelFetch(m_hi, int(id)).xyz;
    const vec3 outside = max(max(lo - p, p - up), vec3(0.0));
    const float box_distance2 = dot(outside, outside);
    if (box_distance2 > cutoff * cutoff) continue;
#ifdef BARNES_HUT
    if (box_distance2 > 0.0) {
      const vec4 com = texelFetch(m_com, int(id));
      const vec3 extent = up - lo;
      const vec3 delta = p - com.xyz;
      const float r = length(delta);
      const uvec4 node_mask = texelFetch(m_mask, int(id));
      if (max(extent.x, max(extent.y, extent.z)) < pc.theta * r && ms_texel_includes(node_mask, mine.xy, mine2)) {
        const float scale = SUPPORT * min(hi_, texelFetch(m_lo, int(id)).w);
        const float d = max(r / scale, 1e-3);
        if (d < 1.0) {
          pairs += uint(com.w);
          const float x = d * PI * 0.5;
          const float c = cos(x) / sin(x);
          energy += com.w * (c + x - PI * 0.5);
          grad += com.w * (-0.5 * PI * c * c) * delta / (r * scale);
        }
        continue;
      }
    }
#endif
    const uvec4 node = texelFetch(nodes, int(id));
    const uint children = node.w & 0xffu;
    if (children == 0) {
      for (uint q = node.x; q < node.x + node.y && work < WORK_BUDGET; ++q) {
        ++work;
        const uint j = order[q];
        if (j == i) continue;
        if (!ms_texel_includes(texelFetch(masks, int(j)), mine.xy, mine2)) continue;  // j's feature does not bound i's
        const vec4 pj = texelFetch(particles, int(j));
        const vec3 delta = p - pj.xyz;
        const float r = length(delta);
#ifdef NEIGHBOUR_LIST
        if (r >= SUPPORT * min(hi_, pj.w) * (1.0 + pc.skin)) continue;
        if (pairs < pc.capacity) lists[list_start + pairs] = j;
        ++pairs;
#else
        if (add_pair_energy(delta, r, SUPPORT * min(hi_, pj.w), energy, grad)) ++pairs;
#endif
      }
    } else if (sp + children <= STACK) {
      for (uint c = 0; c < children; ++c) stack[sp++] = node.z + c;
    } else {
      work = WORK_BUDGET;  // cannot happen for depth <= 22; report rather than drop nodes
    }
  }
#ifdef NEIGHBOUR_LIST
  atomicMax(longest[0], pairs);
#else
  result[i] = vec4(grad, energy);
#endif
  counts[i] = pairs | ((sp > 0 || work >= WORK_BUDGET) ? 0x80000000u : 0u);
  visits[i] = visited;
}
