#version 450
// Octree build, per level L (octree::OctreeBuild): flags the particles that start a child node at level L + 1: those
// inside an internal node of level L (more than leaf_size particles, L < 21) where the (L + 1)-level Morton prefix
// changes, or at their node's start. The flagged indices are then compacted into the child starts.
// Bindings: 0 keys uvec2[n] (sorted); 1 nodes uvec4[] (level L at level_info[L]); 2 level_info uvec2[] (base, count
//           per level); 3 flags uint[n].
// Push: n, level L, leaf_size. Dispatch: n threads, 256 per workgroup. Loops: a binary search (<= 32 steps).
// Reference: ref::build_octree.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "octree.glsl"

layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Keys { uvec2 keys[]; };
layout(std430, binding = 1) readonly buffer Nodes { uvec4 nodes[]; };
layout(std430, binding = 2) readonly buffer LevelInfo { uvec2 level_info[]; };
layout(std430, binding = 3) writeonly buffer Flags { uint flags[]; };
layout(push_constant) uniform Push { uint n; uint level; uint leaf_size; } pc;

void main() {
  const uint i = flat_group_id() * 256 + gl_LocalInvocationID.x;
  if (i >= pc.n) return;
  const uvec2 info = level_info[pc.level];
  // The level-L node holding particle i: the last one whose start is <= i.
  uint lo = 0, hi = info.y;  // candidates [lo, hi)
  for (uint step = 0; step < 32 && hi - lo > 1; ++step) {
    const uint mid = (lo + hi) / 2;
    if (nodes[info.x + mid].x <= i) lo = mid; else hi = mid;
  }
  uint flag = 0;
  if (info.y > 0) {
    const uvec4 node = nodes[info.x + lo];
    const bool inside = i >= node.x && i < node.x + node.y;
    if (inside && node.y > pc.leaf_size && pc.level < OCTREE_MAX_LEVEL) {
      const uint shift = 63 - 3 * (pc.level + 1);
      flag = (i == node.x || shr64(keys[i], shift) != shr64(keys[i - 1], shift)) ? 1u : 0u;
    }
  }
  flags[i] = flag;
}
