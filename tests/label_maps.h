#pragma once
// Label maps for the tests (small labels, the corpus, the well-composed repair): uniform blocks and the 6-connected
// components of a label.
#include <algorithm>
#include <cstdint>
#include <vector>

#include "io/volume.h"

namespace cpmesh::test {

// An n^3 label map of one label.
inline io::LabelVolume block(int64_t n, uint16_t fill) {
  io::LabelVolume v;
  v.dims = {n, n, n};
  v.labels.assign(size_t(n * n * n), fill);
  return v;
}

// Sizes of the 6-connected components of `label`.
inline std::vector<int64_t> components(const io::LabelVolume& v, uint16_t label) {
  std::vector<uint8_t> seen(v.labels.size());
  std::vector<int64_t> sizes;
  for (size_t start = 0; start < v.labels.size(); ++start) {
    if (seen[start] || v.labels[start] != label) continue;
    std::vector<size_t> stack{start};
    seen[start] = 1;
    int64_t n = 0;
    while (!stack.empty()) {
      const size_t at = stack.back();
      stack.pop_back();
      ++n;
      const int64_t i = int64_t(at % size_t(v.dims[0])), j = int64_t(at / size_t(v.dims[0]) % size_t(v.dims[1])),
                    k = int64_t(at / size_t(v.dims[0] * v.dims[1]));
      const int64_t nb[6][3] = {{i - 1, j, k}, {i + 1, j, k}, {i, j - 1, k}, {i, j + 1, k}, {i, j, k - 1}, {i, j, k + 1}};
      for (const auto& q : nb) {
        if (q[0] < 0 || q[1] < 0 || q[2] < 0 || q[0] >= v.dims[0] || q[1] >= v.dims[1] || q[2] >= v.dims[2]) continue;
        const size_t w = v.index(q[0], q[1], q[2]);
        if (!seen[w] && v.labels[w] == label) seen[w] = 1, stack.push_back(w);
      }
    }
    sizes.push_back(n);
  }
  std::sort(sizes.begin(), sizes.end());
  return sizes;
}

}  // namespace cpmesh::test
