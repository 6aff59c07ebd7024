#version 450
// Stream compaction (gpu::Compact), final step: writes the kept items in their original order (the kept count is
// the total of the scan that produced `offsets`).
// Bindings: 0 flags uint[n] (kept where != 0); 1 offsets uint[n] (exclusive scan of flags != 0); 2 values uint[n]
//           (ignored when WRITE_INDEX); 3 out uint[>= kept].
// Push: n. Spec constant 0 WRITE_INDEX: when 1, out receives the indices i instead of values[i].
// Dispatch: n threads, 256 per workgroup. Reference: ref::compact.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = 256) in;
layout(constant_id = 0) const uint WRITE_INDEX = 0;
layout(std430, binding = 0) readonly buffer Flags { uint flags[]; };
layout(std430, binding = 1) readonly buffer Offsets { uint offsets[]; };
layout(std430, binding = 2) readonly buffer Values { uint values[]; };
layout(std430, binding = 3) writeonly buffer Out { uint outv[]; };
layout(push_constant) uniform Push { uint n; } pc;

void main() {
  const uint i = flat_group_id() * 256 + gl_LocalInvocationID.x;
  if (i >= pc.n) return;
  if (flags[i] != 0) {
    uint v = i;
    if (WRITE_INDEX == 0) v = values[i];
    outv[offsets[i]] = v;
  }
}
