#pragma once
#include <cstddef>
#include <cstdint>

namespace cpmesh {

// One compiled compute shader, embedded in the binary at build time (cmake/shaders.cmake).
struct ShaderCode {
  const char* name;
  const uint32_t* words;
  size_t word_count;
};

}  // namespace cpmesh
