#pragma once
// Evenness of a particle sampling: the spread (std / mean) of the nearest-neighbour distances, by brute force.
#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::test {

struct Spacing {
  double mean = 0, spread = 0;
};

inline Spacing nearest_neighbour_spacing(const std::vector<glm::vec4>& p) {
  std::vector<double> nn(p.size(), 1e30);
  for (size_t i = 0; i < p.size(); ++i)
    for (size_t j = 0; j < p.size(); ++j)
      if (i != j) nn[i] = std::min(nn[i], double(glm::length(glm::vec3(p[i]) - glm::vec3(p[j]))));
  Spacing s;
  s.mean = std::accumulate(nn.begin(), nn.end(), 0.0) / double(nn.size());
  double var = 0;
  for (double d : nn) var += (d - s.mean) * (d - s.mean);
  s.spread = std::sqrt(var / double(nn.size())) / s.mean;
  return s;
}

}  // namespace cpmesh::test
