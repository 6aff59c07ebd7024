#include "mesh/surface_slivers.h"

#include <algorithm>
#include <cmath>

#include "mesh/elements_around.h"
#include "mesh/quality.h"
#include "mesh/smooth.h"

namespace cpmesh::mesh {
namespace {

using Tet = std::array<uint32_t, 4>;
using Triangle = std::array<uint32_t, 3>;

double signed_volume(const std::vector<glm::dvec3>& P, const Tet& t) {
  return glm::dot(P[t[1]] - P[t[0]], glm::cross(P[t[2]] - P[t[0]], P[t[3]] - P[t[0]]));
}

glm::dvec3 normal_of(const std::vector<glm::dvec3>& P, const Triangle& t) {
  return glm::cross(P[t[1]] - P[t[0]], P[t[2]] - P[t[0]]);
}

// Every face through v is shared by exactly two of v's tets: v's tets tile a ball around it, not a part of one (v on
// the mesh's outer boundary, or tets missing where a run left a part out).
bool closed_star(uint32_t v, std::span<const uint32_t> mine, const std::vector<Tet>& tets) {
  std::vector<std::array<uint32_t, 2>> edges;  // the face (v, a, b) as (a, b), a < b
  for (uint32_t t : mine) {
    std::array<uint32_t, 3> other{};
    size_t n = 0;
    for (uint32_t u : tets[t])
      if (u != v && n < 3) other[n++] = u;
    if (n != 3) return false;
    for (int i = 0; i < 3; ++i) {
      const uint32_t a = other[size_t(i)], b = other[size_t((i + 1) % 3)];
      edges.push_back({std::min(a, b), std::max(a, b)});
    }
  }
  std::sort(edges.begin(), edges.end());
  for (size_t i = 0; i < edges.size(); i += 2)
    if (i + 1 >= edges.size() || edges[i] != edges[i + 1] || (i + 2 < edges.size() && edges[i + 2] == edges[i]))
      return false;
  return true;
}

// How good vertex v's neighbourhood is at its current position: how many of its tets are under the bound, and the
// smallest dihedral angle among them. `valid` is false where a tet turned over (against `sign`) or went over
// `radius_edge`, or an interface triangle of v fell under `min_ratio` or turned more than 30 degrees from `normals`.
struct Score {
  bool valid = false;
  size_t below = 0;
  double worst = 0;
  bool better_than(const Score& o) const {
    return valid && (!o.valid || below < o.below || (below == o.below && worst > o.worst));
  }
};

class Mover {
 public:
  Mover(std::vector<glm::dvec3>& P, const std::vector<Tet>& tets, const std::vector<Triangle>& triangles,
        const FeatureProjection& project, double target, double max_radius_edge)
      : P_(P), tets_(tets), triangles_(triangles), project_(project), target_(target),
        max_radius_edge_(max_radius_edge), tets_around_(P.size(), tets), triangles_around_(P.size(), triangles) {}

  double min_angle(uint32_t t) const { return min_dihedral(P_, tets_[t]); }
  std::span<const uint32_t> tets_around(uint32_t v) const { return tets_around_[v]; }

  // Tries to move v (in_plane: in the plane of its triangles, else in any direction); true if it moved.
  bool move(uint32_t v, bool in_plane, int pass) {
    const auto mine = tets_around_[v];
    const auto faces = triangles_around_[v];
    if (mine.empty() || faces.empty() || !closed_star(v, mine, tets_)) return false;
    sign_.clear();
    double limit = 1.5 * max_radius_edge_, edge = 0;
    for (uint32_t t : mine) {
      const Tet& k = tets_[t];
      sign_.push_back(signed_volume(P_, k) > 0 ? 1 : -1);
      limit = std::max(limit, radius_edge_ratio(P_[k[0]], P_[k[1]], P_[k[2]], P_[k[3]]));
    }
    normals_.clear();
    glm::dvec3 normal(0.0);
    double min_ratio = 1;
    for (uint32_t f : faces) {
      const Triangle& tri = triangles_[f];
      normals_.push_back(glm::normalize(normal_of(P_, tri)));
      normal += normal_of(P_, tri);
      min_ratio = std::min(min_ratio, radius_ratio(P_[tri[0]], P_[tri[1]], P_[tri[2]]));
      for (uint32_t u : tri) edge += glm::length(P_[u] - P_[v]) / 2;  // each triangle's two edges at v
    }
    if (glm::length(normal) == 0) return false;
    normal = glm::normalize(normal);
    edge /= double(faces.size());
    min_ratio = std::min(min_ratio, 0.5);
    const glm::dvec3 start = P_[v];
    Score best = score(v, limit, min_ratio);
    glm::dvec3 best_at = start;
    constexpr double kSteps[] = {0.5, 0.3, 0.2, 0.12, 0.06, 0.03};
    constexpr int kDraws = 12;
    uint64_t draw = 0;
    for (double step : kSteps)
      for (int d = 0; d < kDraws && best.below > 0; ++d, ++draw) {  // until none of v's tets is under the bound
        const uint64_t key = (uint64_t(v) << 20) ^ (uint64_t(pass) << 12) ^ draw;
        glm::dvec3 dir(hashed_normal(3 * key), hashed_normal(3 * key + 1), hashed_normal(3 * key + 2));
        if (in_plane) dir -= glm::dot(dir, normal) * normal;
        if (glm::length(dir) == 0) continue;
        glm::dvec3 on;
        if (!project_(v, best_at + step * edge * glm::normalize(dir), on)) continue;
        P_[v] = on;
        const Score s = score(v, limit, min_ratio);
        if (s.better_than(best)) best = s, best_at = on;
      }
    P_[v] = best_at;
    return best_at != start;
  }

 private:
  Score score(uint32_t v, double limit, double min_ratio) const {
    Score s;
    const auto mine = tets_around_[v];
    s.worst = M_PI;
    for (size_t i = 0; i < mine.size(); ++i) {
      const Tet& k = tets_[mine[i]];
      if (signed_volume(P_, k) * sign_[i] <= 0) return s;
      if (radius_edge_above(P_[k[0]], P_[k[1]], P_[k[2]], P_[k[3]], limit)) return s;
      const double a = min_dihedral(P_, k);
      s.below += a < target_;
      s.worst = std::min(s.worst, a);
    }
    const auto faces = triangles_around_[v];
    for (size_t i = 0; i < faces.size(); ++i) {
      const Triangle& tri = triangles_[faces[i]];
      if (radius_ratio(P_[tri[0]], P_[tri[1]], P_[tri[2]]) < min_ratio) return s;
      const glm::dvec3 n = normal_of(P_, tri);
      if (glm::dot(n, normals_[i]) <= std::cos(M_PI / 6) * glm::length(n)) return s;
    }
    s.valid = true;
    return s;
  }

  std::vector<glm::dvec3>& P_;
  const std::vector<Tet>& tets_;
  const std::vector<Triangle>& triangles_;
  const FeatureProjection& project_;
  const double target_, max_radius_edge_;
  const ElementsAround<4> tets_around_;
  const ElementsAround<3> triangles_around_;
  std::vector<int8_t> sign_;
  std::vector<glm::dvec3> normals_;
};

}  // namespace

SurfaceSliverReport move_surface_vertices(std::vector<glm::dvec3>& points, const std::vector<Tet>& tets,
                                          const std::vector<Triangle>& triangles, const std::vector<uint8_t>& movable,
                                          const FeatureProjection& project, double target_deg,
                                          double max_radius_edge, int passes) {
  SurfaceSliverReport report;
  const double target = target_deg * M_PI / 180;
  auto is_movable = [&](uint32_t v) { return v < movable.size() && movable[v]; };
  auto with_movable = [&](const Tet& t) { return std::any_of(t.begin(), t.end(), is_movable); };
  auto slivers = [&] {
    std::vector<uint32_t> bad;
    for (uint32_t t = 0; t < tets.size(); ++t)
      if (with_movable(tets[t]) && min_dihedral(points, tets[t]) < target) bad.push_back(t);
    return bad;
  };
  std::vector<uint32_t> bad = slivers();
  report.slivers_before = report.slivers_after = bad.size();
  if (bad.empty()) return report;
  Mover mover(points, tets, triangles, project, target, max_radius_edge);
  // A vertex is tried again only once something in its star has moved since it last failed.
  std::vector<uint8_t> stale(points.size(), 0);
  for (int pass = 0; pass < passes && !bad.empty(); ++pass) {
    size_t moved = 0;
    for (uint32_t t : bad)
      for (uint32_t v : tets[t]) {
        if (!is_movable(v) || stale[v] || mover.min_angle(t) >= target) continue;
        if (!mover.move(v, movable[v] == 1, pass)) {
          stale[v] = 1;
          continue;
        }
        ++moved;
        for (uint32_t k : mover.tets_around(v))
          for (uint32_t u : tets[k]) stale[u] = 0;
      }
    report.moves += moved;
    bad = slivers();  // a move may leave a tet of its star under the bound where it lifts another
    if (moved == 0) break;
  }
  report.slivers_after = bad.size();
  return report;
}

}  // namespace cpmesh::mesh
