#pragma once
// Shared by the GPU tests: one context per test executable (validation on when the layers are installed; the CTest
// entry also sets CPMESH_VALIDATION=1), and a fixture that fails the test case on any new validation error.
#include <doctest/doctest.h>

#include <random>
#include <string>
#include <vector>

#include "gpu/context.h"

namespace cpmesh::test {

inline gpu::Context& gpu_context() {
  static gpu::Context ctx(gpu::ContextOptions{"", true, false});
  return ctx;
}

struct GpuFixture {
  gpu::Context& ctx = gpu_context();
  uint64_t errors_before = ctx.validation_error_count();
  ~GpuFixture() {
    const auto errors = ctx.validation_errors();
    for (size_t i = errors_before; i < errors.size(); ++i) {
      const std::string message = "Vulkan validation error: " + errors[i];
      FAIL_CHECK(message);
    }
    CHECK(ctx.validation_error_count() == errors_before);
  }
};

inline std::vector<uint32_t> random_u32(size_t n, uint64_t seed, uint32_t modulo = 0) {
  std::mt19937_64 rng(seed);
  std::vector<uint32_t> v(n);
  for (auto& x : v) x = modulo ? uint32_t(rng() % modulo) : uint32_t(rng());
  return v;
}

// Sizes every building block is tested at: empty, one, around the workgroup (256) and block (1024, 2048) sizes, and
// non-powers of two.
inline const std::vector<uint32_t>& edge_sizes() {
  static const std::vector<uint32_t> sizes = {0, 1, 2, 7, 255, 256, 257, 1023, 1024, 1025, 2047, 2048, 2049, 5000};
  return sizes;
}

}  // namespace cpmesh::test
