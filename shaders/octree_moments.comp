#version 450
// Octree upsweep, one level (octree::OctreeMoments): per node, the bounding box of its particles, their smallest
// sizing h, centre of mass and count, and the intersection of their features' material sets
// (fields::MaterialSet::common; the far-field approximation of the tree walk may only lump a node whose every
// particle interacts with the walker); leaves from their particles, internal nodes from their (at most 8) children.
// Run from level 21 up to the root.
// Bindings: 0 nodes usamplerBuffer (uvec4 texels); 1 level_info uvec2[22]; 2 order uint[n] (Morton order ->
//           particle); 3 particles samplerBuffer (xyz position, w sizing h); 4-7 the moments, one vec4 per node in
//           each: lo (box min, min h), hi (box max, 0), com (centre, count), and_mask (the AND of the masks, then
//           with EXACT_SETS the intersection of the slots, else 0, as float bits) (four buffers so that each stays
//           within maxStorageBufferRange for a million particles); 8 masks usamplerBuffer (per particle: its feature's material set, material_set.glsl).
// Push: level. Dispatch: n threads (guarded by the level's node count), 256 per workgroup.
// Loops: at most LEAF_LOOP particles (more only in a level-21 leaf, whose particles share one 63-bit key, i.e. one
// position to 2^-21 of the box) or 8 children. Reference: ref::octree_moments.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "material_set.glsl"

layout(local_size_x = 256) in;
layout(binding = 0) uniform usamplerBuffer nodes;  // texel buffers: lavapipe gathers them (tree_walk.comp)
layout(std430, binding = 1) readonly buffer LevelInfo { uvec2 level_info[]; };
layout(std430, binding = 2) readonly buffer Order { uint order[]; };
layout(binding = 3) uniform samplerBuffer particles;
layout(std430, binding = 4) buffer MomentsLo { vec4 m_lo[]; };
layout(std430, binding = 5) buffer MomentsHi { vec4 m_hi[]; };
layout(std430, binding = 6) buffer MomentsCom { vec4 m_com[]; };
layout(std430, binding = 7) buffer MomentsMask { vec4 m_mask[]; };
layout(binding = 8) uniform usamplerBuffer masks;
layout(push_constant) uniform Push { uint level; } pc;

const uint LEAF_LOOP = 4096;

void main() {
  const uint g = flat_group_id() * 256 + gl_LocalInvocationID.x;
  const uvec2 info = level_info[pc.level];
  if (g >= info.y) return;
  const uint id = info.x + g;
  const uvec4 node = texelFetch(nodes, int(id));
  const uint children = node.w & 0xffu;
  vec3 lo = vec3(3.4e38), hi = vec3(-3.4e38), sum = vec3(0.0);
  float min_h = 3.4e38;
  float total = 0.0;
  uvec2 and_bits = uvec2(0xffffffffu), and_set = uvec2(0xffffffffu);
  if (children == 0) {
    const uint m = min(node.y, LEAF_LOOP);
    for (uint k = 0; k < m; ++k) {
      const uint particle = order[node.x + k];
      const uvec4 set = texelFetch(masks, int(particle));
      and_bits &= set.xy;
      if (EXACT_SETS != 0u) and_set = k == 0u ? set.zw : ms_common(and_set, set.zw);
      const vec4 p = texelFetch(particles, int(particle));
      lo = min(lo, p.xyz);
      hi = max(hi, p.xyz);
      min_h = min(min_h, p.w);
      sum += p.xyz;
    }
    total = float(node.y);
    if (m > 0) sum /= float(m);
  } else {
    for (uint c = 0; c < children; ++c) {
      const uint child = node.z + c;
      const vec4 a = m_lo[child], b = m_hi[child], com = m_com[child];
      const uvec4 set = floatBitsToUint(m_mask[child]);
      and_bits &= set.xy;
      if (EXACT_SETS != 0u) and_set = c == 0u ? set.zw : ms_common(and_set, set.zw);
      lo = min(lo, a.xyz);
      hi = max(hi, b.xyz);
      min_h = min(min_h, a.w);
      sum += com.xyz * com.w;
      total += com.w;
    }
    if (total > 0.0) sum /= total;
  }
  m_lo[id] = vec4(lo, min_h);
  m_hi[id] = vec4(hi, 0.0);
  m_com[id] = vec4(sum, total);
  m_mask[id] = uintBitsToFloat(uvec4(and_bits, EXACT_SETS != 0u ? and_set : uvec2(0u)));
}
