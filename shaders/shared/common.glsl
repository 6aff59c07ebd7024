// Helpers shared by every compute shader.
#ifndef CPMESH_COMMON_GLSL
#define CPMESH_COMMON_GLSL

// Linear workgroup index. gpu::Sequence spreads large dispatches over y when the group count exceeds
// maxComputeWorkGroupCount[0], so shaders index with this, never gl_WorkGroupID.x alone, and guard the tail.
uint flat_group_id() { return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x; }

// Finiteness from the bits: Vulkan lets an implementation assume no NaN or infinity unless a shader declares
// SignedZeroInfNanPreserve, so isnan / isinf (and comparisons meant to catch a NaN) may be folded away.
bool finite_bits(float x) { return (floatBitsToUint(x) & 0x7f800000u) != 0x7f800000u; }
bool finite_bits(vec3 v) { return finite_bits(v.x) && finite_bits(v.y) && finite_bits(v.z); }
bool finite_bits(vec4 v) { return finite_bits(v.xyz) && finite_bits(v.w); }

#endif
