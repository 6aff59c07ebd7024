#include "mesh/smooth.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mesh/quality.h"
#include "ref/cp_lookup.h"

namespace cpmesh::mesh {

namespace {

glm::dvec3 normal_of(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) { return glm::cross(b - a, c - a); }

}  // namespace

SmoothReport smooth_interfaces(const fields::IndicatorFields& fields, const fields::ClosestPointEmbedding& E,
                               const std::vector<uint32_t>& vertex_feature, InterfaceMesh& mesh,
                               const SmoothOptions& options) {
  SmoothReport report;
  const size_t nv = mesh.vertices.size();
  auto& V = mesh.vertices;
  const auto& T = mesh.triangles;
  // Incident triangles of each vertex, and the curve neighbours of each curve vertex: the other ends of its
  // triple-curve edges whose feature bounds or is its curve (a quadruple point ends a curve).
  std::vector<std::vector<uint32_t>> around(nv);
  for (uint32_t t = 0; t < T.size(); ++t)
    for (uint32_t v : T[t]) around[v].push_back(t);
  std::vector<std::vector<uint32_t>> along(nv);
  for (const auto& e : triple_curve_edges(T, mesh.pair)) {
    const auto& fa = E.features[vertex_feature[e.a]];
    const auto& fb = E.features[vertex_feature[e.b]];
    const uint64_t ma = fa.material_mask(), mb = fb.material_mask();
    if (fa.kind == fields::FeatureKind::triple_curve && (mb & ma) == ma) along[e.a].push_back(e.b);
    if (fb.kind == fields::FeatureKind::triple_curve && (ma & mb) == mb) along[e.b].push_back(e.a);
  }
  auto worst_around = [&](uint32_t v) {
    double worst = 1;
    for (uint32_t t : around[v]) worst = std::min(worst, radius_ratio(V[T[t][0]], V[T[t][1]], V[T[t][2]]));
    return worst;
  };

  std::vector<glm::dvec3> proposal(nv);
  std::vector<uint8_t> has(nv);
  for (int round = 0; round < options.rounds; ++round) {
    // Targets and their projections, in parallel from this round's positions.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nv), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t v = r.begin(); v < r.end(); ++v) {
        has[v] = 0;
        if (around[v].empty()) continue;
        const auto kind = E.features[vertex_feature[v]].kind;
        glm::dvec3 target;
        if (kind == fields::FeatureKind::interface) {
          glm::dvec3 sum(0.0);
          double area = 0;
          for (uint32_t t : around[v]) {
            const glm::dvec3 &a = V[T[t][0]], &b = V[T[t][1]], &c = V[T[t][2]];
            const double w = 0.5 * glm::length(normal_of(a, b, c));
            sum += w * (a + b + c) / 3.0;
            area += w;
          }
          if (area <= 0) continue;
          target = sum / area;
        } else if (kind == fields::FeatureKind::triple_curve && along[v].size() == 2) {
          target = 0.5 * (V[along[v][0]] + V[along[v][1]]);
        } else {
          continue;  // quadruple points, and curve vertices whose curve neighbours are not a clean pair
        }
        const glm::dvec3 moved = V[v] + options.step * (target - V[v]);
        const auto cp = ref::cp_lookup(E, glm::vec3(moved), vertex_feature[v]);
        glm::dvec3 foot;
        if (cp.valid) {
          foot = glm::dvec3(glm::vec3(cp.value));
        } else if (!fields::project_to_feature(fields, E.features[vertex_feature[v]], moved, foot, 30, 3, &V[v])) {
          continue;
        }
        proposal[v] = foot;
        has[v] = 1;
      }
    });
    // Accepted one vertex at a time against the current positions: no triangle may flip, the worst one around the
    // vertex may not get worse.
    size_t moves = 0;
    for (uint32_t v = 0; v < nv; ++v) {
      if (!has[v]) continue;
      const glm::dvec3 old = V[v];
      const double before = worst_around(v);
      std::vector<glm::dvec3> normals;
      for (uint32_t t : around[v]) normals.push_back(normal_of(V[T[t][0]], V[T[t][1]], V[T[t][2]]));
      V[v] = proposal[v];
      bool ok = worst_around(v) >= before;
      for (size_t k = 0; k < around[v].size() && ok; ++k) {
        const auto& tri = T[around[v][k]];
        ok = glm::dot(normal_of(V[tri[0]], V[tri[1]], V[tri[2]]), normals[k]) > 0;
      }
      if (ok) {
        ++moves;
      } else {
        V[v] = old;
        ++report.refused;
      }
    }
    report.moves += moves;
    ++report.rounds;
    if (moves == 0) break;
  }
  return report;
}

TetImproveReport improve_tets(std::vector<glm::dvec3>& P, const std::vector<std::array<uint32_t, 4>>& tets,
                              size_t fixed, double target_deg, double max_radius_edge, int passes) {
  TetImproveReport report;
  const double target = target_deg * M_PI / 180;
  auto signed_volume = [&](const std::array<uint32_t, 4>& t) {
    return glm::dot(P[t[1]] - P[t[0]], glm::cross(P[t[2]] - P[t[0]], P[t[3]] - P[t[0]]));
  };
  auto min_angle = [&](const std::array<uint32_t, 4>& t) {
    const auto a = dihedral_angles(P[t[0]], P[t[1]], P[t[2]], P[t[3]]);
    return *std::min_element(a.begin(), a.end());
  };
  std::vector<std::vector<uint32_t>> around(P.size());
  std::vector<int8_t> sign(tets.size());
  double worst = M_PI;
  for (uint32_t t = 0; t < tets.size(); ++t) {
    for (uint32_t v : tets[t]) around[v].push_back(t);
    sign[t] = signed_volume(tets[t]) > 0 ? 1 : -1;
    worst = std::min(worst, min_angle(tets[t]));
  }
  report.min_dihedral_before = report.min_dihedral_after = worst * 180 / M_PI;
  // The smallest dihedral angle of v's tets with v at its current position, or -1 if one of them is inverted or
  // over the radius-edge bound `limit`.
  auto quality_at = [&](uint32_t v, double limit) {
    double q = M_PI;
    for (uint32_t t : around[v]) {
      const auto& k = tets[t];
      if (signed_volume(k) * sign[t] <= 0 || radius_edge_ratio(P[k[0]], P[k[1]], P[k[2]], P[k[3]]) > limit) return -1.0;
      q = std::min(q, min_angle(k));
    }
    return q;
  };
  // The largest radius-edge ratio among v's tets.
  auto radius_edge_at = [&](uint32_t v) {
    double r = 0;
    for (uint32_t t : around[v]) {
      const auto& k = tets[t];
      r = std::max(r, radius_edge_ratio(P[k[0]], P[k[1]], P[k[2]], P[k[3]]));
    }
    return r;
  };
  std::mt19937 rng(12345);
  std::normal_distribution<double> n01;
  for (int pass = 0; pass < passes; ++pass) {
    size_t moves = 0;
    for (uint32_t t = 0; t < tets.size(); ++t) {
      if (min_angle(tets[t]) >= target) continue;
      for (uint32_t v : tets[t]) {
        if (v < fixed) continue;
        const glm::dvec3 start = P[v];
        const double limit = std::max(max_radius_edge, radius_edge_at(v));  // never worse than the bound or now
        double best = quality_at(v, limit);
        glm::dvec3 best_at = start, centroid(0.0);
        double edge = 0;
        size_t count = 0;
        for (uint32_t u : around[v])
          for (uint32_t w : tets[u])
            if (w != v) {
              centroid += P[w];
              edge += glm::length(P[w] - start);
              ++count;
            }
        if (count == 0) continue;
        centroid /= double(count);
        edge /= double(count);
        auto consider = [&](const glm::dvec3& at) {
          P[v] = at;
          const double q = quality_at(v, limit);
          if (q > best) best = q, best_at = at;
        };
        consider(centroid);
        for (double step = 0.2 * edge; step > 0.01 * edge; step *= 0.5)
          for (int k = 0; k < 8; ++k) consider(best_at + step * glm::dvec3(n01(rng), n01(rng), n01(rng)) / std::sqrt(3.0));
        P[v] = best_at;
        moves += best_at != start;
      }
    }
    report.moves += moves;
    if (moves == 0) break;
  }
  worst = M_PI;
  for (const auto& t : tets) worst = std::min(worst, min_angle(t));
  report.min_dihedral_after = worst * 180 / M_PI;
  return report;
}

}  // namespace cpmesh::mesh
