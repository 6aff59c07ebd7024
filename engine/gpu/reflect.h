#pragma once
// Minimal SPIR-V reflection for compute shaders: what a Kernel needs to build its pipeline layout without hand-written
// descriptions. Supports the shapes our shaders use: storage buffers and uniform texel buffers (samplerBuffer read
// as RGBA32F texels, usamplerBuffer as RGBA32UI) in set 0 at bindings 0..n-1, one push-constant block of scalars,
// vectors, matrices, arrays and nested structs, and a literal local size.
#include <cstdint>
#include <string>

#include "gpu/shader_code.h"

namespace cpmesh::gpu {

struct ShaderLayout {
  uint32_t bindings = 0;            // bindings 0..bindings-1 in set 0: storage buffers, but ...
  uint32_t texel_buffers = 0;       // ... bit b set: binding b is a uniform texel buffer (RGBA32F) ...
  uint32_t uint_texels = 0;         // ... of RGBA32UI texels when bit b is set here too (usamplerBuffer)
  uint32_t push_constant_bytes = 0; // 0 when the shader has no push constants
  uint32_t local_size[3] = {1, 1, 1};
  uint32_t spec_constants = 0;      // number of distinct constant_id decorations
};

// Throws gpu::Error naming the shader when the module is malformed or uses an unsupported shape.
ShaderLayout reflect(const ShaderCode& code);

}  // namespace cpmesh::gpu
