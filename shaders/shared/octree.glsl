// Shared by the octree build kernels (octree::OctreeBuild; reference ref::build_octree).
// A node is uvec4(start, count, first_child, level << 8 | child_count) over the Morton-sorted particles; the nodes of
// one level are stored consecutively in particle order, levels one after another from the root (node 0).
#ifndef CPMESH_OCTREE_GLSL
#define CPMESH_OCTREE_GLSL

const uint OCTREE_MAX_LEVEL = 21;  // 63-bit keys: 3 bits per level

uvec2 shr64(uvec2 k, uint s) {  // (high:low) >> s, s in [0, 63]
  if (s == 0) return k;
  if (s >= 32) return uvec2(k.y >> (s - 32), 0u);
  return uvec2((k.x >> s) | (k.y << (32 - s)), k.y >> s);
}

#endif
