#include "ref/population_flags.h"

#include <algorithm>

namespace cpmesh::ref {

void population_flags(const std::vector<glm::vec4>& walk, const std::vector<uint32_t>& features,
                      const std::vector<float>& ideals, float delete_factor, float add_factor,
                      std::vector<uint32_t>& flags, std::vector<uint32_t>& counters) {
  flags.assign(walk.size(), 0u);
  counters.assign(2 + 2 * ideals.size(), 0u);
  for (size_t i = 0; i < walk.size(); ++i) {
    const uint32_t f = features[i];
    const float ideal = ideals[f];
    if (!(ideal > 0.0f)) continue;
    const float e = walk[i].w;
    uint32_t flag = 0;
    if (e > delete_factor * ideal) flag = 1;
    else if (e < add_factor * ideal) flag = 2;
    if (flag != 0) ++counters[flag - 1];
    counters[2 + 2 * f] += uint32_t(std::min(e / ideal, 16.0f) * 64.0f + 0.5f);
    ++counters[3 + 2 * f];
    flags[i] = flag;
  }
}

}  // namespace cpmesh::ref
