#include "ref/particle_energy.h"

#include <algorithm>
#include <cmath>

namespace cpmesh::ref {

std::vector<glm::vec4> particle_energy(const std::vector<glm::vec4>& particles, const std::vector<uint32_t>& features,
                                       const std::vector<fields::MaterialSet>& masks) {
  const float pi = 3.14159265358979f, support = 1.7320508075688772f;
  std::vector<glm::vec4> out(particles.size());
  for (size_t i = 0; i < particles.size(); ++i) {
    const glm::vec3 p(particles[i]);
    const fields::MaterialSet mask = masks[features[i]];
    float energy = 0.0f;
    glm::vec3 grad(0.0f);
    for (size_t j = 0; j < particles.size(); ++j) {
      if (j == i || !masks[features[j]].includes(mask)) continue;
      const glm::vec3 delta = p - glm::vec3(particles[j]);
      const float r = glm::length(delta);
      const float scale = support * std::min(particles[i].w, particles[j].w);
      const float d = std::max(r / scale, 1e-3f);
      if (d >= 1.0f) continue;
      const float x = d * pi * 0.5f;
      const float c = std::cos(x) / std::sin(x);
      energy += c + x - pi * 0.5f;
      if (r > 0.0f) grad += (-0.5f * pi * c * c) * delta / (r * scale);
    }
    out[i] = glm::vec4(grad, energy);
  }
  return out;
}

std::vector<std::vector<uint32_t>> neighbour_lists(const std::vector<glm::vec4>& particles,
                                                   const std::vector<uint32_t>& features,
                                                   const std::vector<fields::MaterialSet>& masks, float skin) {
  const float support = 1.7320508075688772f;
  std::vector<std::vector<uint32_t>> out(particles.size());
  for (size_t i = 0; i < particles.size(); ++i) {
    const glm::vec3 p(particles[i]);
    const fields::MaterialSet mask = masks[features[i]];
    for (size_t j = 0; j < particles.size(); ++j) {
      if (j == i || !masks[features[j]].includes(mask)) continue;
      const float cutoff = support * std::min(particles[i].w, particles[j].w) * (1.0f + skin);
      if (glm::length(p - glm::vec3(particles[j])) < cutoff) out[i].push_back(uint32_t(j));
    }
  }
  return out;
}

float neighbour_drift(const std::vector<glm::vec4>& particles, const std::vector<glm::vec4>& anchors) {
  float worst = 0.0f;
  for (size_t i = 0; i < particles.size(); ++i)
    worst = std::max(worst, glm::length(glm::vec3(particles[i]) - glm::vec3(anchors[i])) / anchors[i].w);
  return worst;
}

}  // namespace cpmesh::ref
