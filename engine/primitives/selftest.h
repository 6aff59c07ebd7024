#pragma once
// Runs every GPU building block on random data on the chosen device and compares it with its C++ reference, so a
// user can check a driver before trusting it with a mesh (`cpmesh selftest`).
#include <string>
#include <vector>

#include "gpu/context.h"

namespace cpmesh::gpu {

struct SelftestResult {
  std::string name;
  uint32_t n = 0;
  bool passed = false;
  std::string detail;  // first mismatch, or the error measured
  double ms = 0.0;     // wall time of the GPU submission
};

std::vector<SelftestResult> run_selftest(Context& ctx, uint32_t n, uint64_t seed = 1);

}  // namespace cpmesh::gpu
