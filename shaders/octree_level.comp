#version 450
// Octree build, per level (octree::OctreeBuild): one thread records where level L + 1 starts in the node array and
// how many nodes it has (the child starts just compacted): level_info[L + 1] = (base[L] + count[L], child count).
// Bindings: 0 level_info uvec2[22]; 1 counts uint[] (count[L + 1] from the compaction).
// Push: level L. Dispatch: 1 thread. Reference: ref::build_octree.
layout(local_size_x = 1) in;
layout(std430, binding = 0) buffer LevelInfo { uvec2 level_info[]; };
layout(std430, binding = 1) readonly buffer Counts { uint counts[]; };
layout(push_constant) uniform Push { uint level; } pc;

void main() {
  const uvec2 here = level_info[pc.level];
  level_info[pc.level + 1] = uvec2(here.x + here.y, counts[pc.level + 1]);
}
