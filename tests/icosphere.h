#pragma once
// Closed triangle surfaces with known insides for the mesh tests: icospheres, their enclosed volume, a tet's volume.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::test {

// An icosphere of radius r about the origin: `levels` subdivisions of the icosahedron, normals pointing inward when
// `inward`, each vertex moved radially by up to `jitter` x its edge length (seeded), which leaves some triangles no
// Delaunay faces of the vertices.
struct Sphere {
  std::vector<glm::dvec3> points;
  std::vector<std::array<uint32_t, 3>> triangles;
};

inline Sphere icosphere(double r, int levels, bool inward, double jitter = 0, uint32_t seed = 1) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  Sphere s;
  s.points = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
              {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  s.triangles = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                 {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
                 {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    auto middle = [&](uint32_t a, uint32_t b) {
      const auto key = std::minmax(a, b);
      const auto [it, added] = mid.emplace(key, uint32_t(s.points.size()));
      if (added) s.points.push_back((s.points[a] + s.points[b]) / 2.0);
      return it->second;
    };
    std::vector<std::array<uint32_t, 3>> finer;
    for (const auto& f : s.triangles) {
      const uint32_t ab = middle(f[0], f[1]), bc = middle(f[1], f[2]), ca = middle(f[2], f[0]);
      finer.insert(finer.end(), {{f[0], ab, ca}, {f[1], bc, ab}, {f[2], ca, bc}, {ab, bc, ca}});
    }
    s.triangles = std::move(finer);
  }
  const double edge = r * 1.05 / double(1 << levels);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-jitter * edge, jitter * edge);
  for (auto& p : s.points) p = glm::normalize(p) * (r + u(rng));
  if (inward)
    for (auto& f : s.triangles) std::swap(f[1], f[2]);
  return s;
}

inline double enclosed_volume(const std::vector<glm::dvec3>& P, const std::vector<std::array<uint32_t, 3>>& T) {
  double v = 0;
  for (const auto& t : T) v += glm::dot(P[t[0]], glm::cross(P[t[1]], P[t[2]])) / 6;
  return v;
}

inline double tet_volume(const std::vector<glm::dvec3>& P, const std::array<uint32_t, 4>& t) {
  return std::fabs(glm::dot(P[t[1]] - P[t[0]], glm::cross(P[t[2]] - P[t[0]], P[t[3]] - P[t[0]]))) / 6;
}

}  // namespace cpmesh::test
