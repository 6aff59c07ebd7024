// Helpers shared by every compute shader.
#ifndef CPMESH_COMMON_GLSL
#define CPMESH_COMMON_GLSL

// Linear workgroup index. gpu::Sequence spreads large dispatches over y when the group count exceeds
// maxComputeWorkGroupCount[0], so shaders index with this, never gl_WorkGroupID.x alone, and guard the tail.
uint flat_group_id() { return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x; }

#endif
