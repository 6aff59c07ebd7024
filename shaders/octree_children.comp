#version 450
// Octree build, per level L (octree::OctreeBuild): turns the compacted child starts into the nodes of level L + 1 and
// links each internal node of level L to its children (the last child of a parent writes first_child, child_count).
// Bindings: 0 starts uint[] (child starts, level_info[L + 1].y of them); 1 nodes uvec4[]; 2 level_info uvec2[].
// Push: n, level L. Dispatch: n threads (guarded by the child count), 256 per workgroup. Loops: binary searches.
// Reference: ref::build_octree.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "octree.glsl"

layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Starts { uint starts[]; };
layout(std430, binding = 1) buffer Nodes { uvec4 nodes[]; };
layout(std430, binding = 2) readonly buffer LevelInfo { uvec2 level_info[]; };
layout(push_constant) uniform Push { uint n; uint level; } pc;

void main() {
  const uint g = flat_group_id() * 256 + gl_LocalInvocationID.x;
  const uvec2 parent_level = level_info[pc.level];
  const uvec2 child_level = level_info[pc.level + 1];
  if (g >= child_level.y) return;
  const uint start = starts[g];
  // Parent: the last level-L node whose start is <= start.
  uint lo = 0, hi = parent_level.y;
  for (uint step = 0; step < 32 && hi - lo > 1; ++step) {
    const uint mid = (lo + hi) / 2;
    if (nodes[parent_level.x + mid].x <= start) lo = mid; else hi = mid;
  }
  const uint parent = parent_level.x + lo;
  const uvec4 p = nodes[parent];
  const uint parent_end = p.x + p.y;
  const bool last = g + 1 == child_level.y || starts[g + 1] >= parent_end;
  const uint end = last ? parent_end : starts[g + 1];
  nodes[child_level.x + g] = uvec4(start, end - start, 0u, (pc.level + 1) << 8);
  if (last) {
    // First child of this parent: the first child start >= the parent's start.
    uint a = 0, b = g;  // answer in [a, b]
    for (uint step = 0; step < 32 && a < b; ++step) {
      const uint mid = (a + b) / 2;
      if (starts[mid] < p.x) a = mid + 1; else b = mid;
    }
    nodes[parent] = uvec4(p.x, p.y, child_level.x + a, (pc.level << 8) | (g - a + 1));
  }
}
