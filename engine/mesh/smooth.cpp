#include "mesh/smooth.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <random>
#include <set>
#include <unordered_map>
#include <span>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "mesh/elements_around.h"
#include "mesh/quality.h"
#include "ref/cp_lookup.h"

namespace cpmesh::mesh {

namespace {

glm::dvec3 normal_of(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) { return glm::cross(b - a, c - a); }

// Where v would make triangle (v, a, b) equilateral: on the perpendicular bisector of ab, in the triangle's plane, on
// v's side, sqrt(3)/2 |ab| from ab's midpoint. False for a degenerate triangle.
bool equilateral_apex(const glm::dvec3& v, const glm::dvec3& a, const glm::dvec3& b, glm::dvec3& apex) {
  const glm::dvec3 edge = b - a, mid = 0.5 * (a + b);
  glm::dvec3 dir = glm::cross(normal_of(v, a, b), edge);
  const double len = glm::length(dir);
  if (!(len > 0)) return false;
  dir /= len;
  if (glm::dot(dir, v - mid) < 0) dir = -dir;
  apex = mid + dir * (glm::length(edge) * std::sqrt(3.0) / 2);
  return true;
}

}  // namespace

size_t undo_crossings(const std::vector<glm::dvec3>& start, const std::vector<std::array<uint32_t, 3>>& T,
                      std::vector<glm::dvec3>& V) {
  size_t undone = 0;
  std::vector<uint8_t> touched(V.size(), 0);  // vertices undone in this pass
  auto undo = [&](uint32_t v) {
    if (V[v] == start[v]) return false;
    V[v] = start[v];
    touched[v] = 1;
    ++undone;
    return true;
  };
  auto flipped = [&](const std::array<uint32_t, 3>& t) {
    return glm::dot(normal_of(V[t[0]], V[t[1]], V[t[2]]), normal_of(start[t[0]], start[t[1]], start[t[2]])) <= 0;
  };
  // Each pass tests only the triangles that changed since they were last tested: at first the moved ones, then
  // those with a vertex the last pass undid. A pair of triangles neither of which changed was tested before and
  // does not cross, and a triangle's flip depends on its own vertices alone, so this finds what testing every
  // moved triangle in every pass finds (that took most of the smoothing on meshes of a million triangles).
  std::vector<uint8_t> check(T.size()), flip(T.size());
  const tbb::blocked_range<size_t> all(0, T.size(), 4096);
  tbb::parallel_for(all, [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t < r.end(); ++t)
      check[t] = V[T[t][0]] != start[T[t][0]] || V[T[t][1]] != start[T[t][1]] || V[T[t][2]] != start[T[t][2]];
  });
  auto touches = [&](size_t t) { return touched[T[t][0]] || touched[T[t][1]] || touched[T[t][2]]; };
  for (;;) {
    bool changed = false;
    for (const auto& pair : crossing_triangles(V, T, &check))
      for (uint32_t t : pair)
        for (uint32_t v : T[t]) changed |= undo(v);
    // Flipped triangles: found in parallel, then undone in triangle order, each checked again against the moves
    // undone before it (a triangle that an undo flips is found in the next pass).
    tbb::parallel_for(all, [&](const tbb::blocked_range<size_t>& r) {
      for (size_t t = r.begin(); t < r.end(); ++t) flip[t] = uint8_t((check[t] || touches(t)) && flipped(T[t]));
    });
    for (size_t t = 0; t < T.size(); ++t)
      if (flip[t] && flipped(T[t]))
        for (uint32_t v : T[t]) changed |= undo(v);
    if (!changed) return undone;
    tbb::parallel_for(all, [&](const tbb::blocked_range<size_t>& r) {
      for (size_t t = r.begin(); t < r.end(); ++t) check[t] = uint8_t(touches(t));
    });
    std::fill(touched.begin(), touched.end(), uint8_t(0));
  }
}

bool onto_feature(const fields::IndicatorFields& fields, const fields::ClosestPointEmbedding& E, uint32_t feature,
                  const glm::dvec3& near, const glm::dvec3& start, glm::dvec3& on) {
  const auto cp = ref::cp_lookup(E, glm::vec3(near), feature);
  if (cp.valid) {
    on = glm::dvec3(glm::vec3(cp.value));
    return true;
  }
  return fields::project_to_feature(fields, E.features[feature], near, on, 30, 3, &start);
}

SmoothReport smooth_interfaces(const fields::IndicatorFields& fields, const fields::ClosestPointEmbedding& E,
                               const std::vector<uint32_t>& vertex_feature, InterfaceMesh& mesh,
                               const SmoothOptions& options) {
  SmoothReport report;
  const size_t nv = mesh.vertices.size();
  auto& V = mesh.vertices;
  const auto& T = mesh.triangles;
  // Incident triangles of each vertex, and the curve neighbours of each curve vertex: the other ends of its
  // triple-curve edges whose feature bounds or is its curve (a quadruple point ends a curve).
  const ElementsAround<3> around(nv, T);
  std::vector<std::vector<uint32_t>> along(nv);
  for (const auto& e : triple_curve_edges(T, mesh.pair)) {
    const auto& fa = E.features[vertex_feature[e.a]];
    const auto& fb = E.features[vertex_feature[e.b]];
    const fields::MaterialSet ma = fa.material_set(), mb = fb.material_set();
    if (fa.kind == fields::FeatureKind::triple_curve && mb.includes(ma)) along[e.a].push_back(e.b);
    if (fb.kind == fields::FeatureKind::triple_curve && ma.includes(mb)) along[e.b].push_back(e.a);
  }
  // The worst and the sum of the radius ratios of v's triangles.
  auto shape_around = [&](uint32_t v) {
    std::array<double, 2> worst_sum{1, 0};
    for (uint32_t t : around[v]) {
      const double q = radius_ratio(V[T[t][0]], V[T[t][1]], V[T[t][2]]);
      worst_sum = {std::min(worst_sum[0], q), worst_sum[1] + q};
    }
    return worst_sum;
  };
  // The mean of the positions that would make each of v's triangles equilateral (v in the surface plane of each).
  auto equilateral_target = [&](uint32_t v, glm::dvec3& target) {
    glm::dvec3 sum(0.0);
    int n = 0;
    for (uint32_t t : around[v]) {
      const auto& tri = T[t];
      const int i = tri[0] == v ? 0 : tri[1] == v ? 1 : 2;
      glm::dvec3 apex;
      if (equilateral_apex(V[v], V[tri[(i + 1) % 3]], V[tri[(i + 2) % 3]], apex)) sum += apex, ++n;
    }
    if (n) target = sum / double(n);
    return n > 0;
  };

  // Greedy colouring in vertex order: two vertices of one triangle never share a colour. by_colour lists the
  // vertices colour by colour (in vertex order within one), colour c at [colour_begin[c], colour_begin[c + 1]).
  std::vector<uint32_t> colour(nv, 0);
  uint32_t colours = 0;
  {
    std::vector<uint32_t> taken;  // taken[c] == v + 1: colour c is used by a neighbour of v
    for (uint32_t v = 0; v < nv; ++v) {
      for (uint32_t t : around[v])
        for (uint32_t u : T[t])
          if (u < v) {
            if (taken.size() <= colour[u]) taken.resize(colour[u] + 1, 0);
            taken[colour[u]] = v + 1;
          }
      uint32_t c = 0;
      while (c < taken.size() && taken[c] == v + 1) ++c;
      colour[v] = c;
      colours = std::max(colours, c + 1);
    }
  }
  std::vector<size_t> colour_begin(colours + 1, 0);
  for (uint32_t v = 0; v < nv; ++v) ++colour_begin[colour[v] + 1];
  for (uint32_t c = 0; c < colours; ++c) colour_begin[c + 1] += colour_begin[c];
  std::vector<uint32_t> by_colour(nv);
  {
    std::vector<size_t> next(colour_begin.begin(), colour_begin.end() - 1);
    for (uint32_t v = 0; v < nv; ++v) by_colour[next[colour[v]]++] = v;
  }

  std::vector<std::array<glm::dvec3, 2>> proposal(nv);
  std::vector<uint8_t> has(nv);  // proposals made for v
  // Crossings (undo_crossings): tested after every round while the last test found some (thin layers), else once
  // after the rounds, back to the positions of the last round tested. The test over every moved triangle was most
  // of the smoothing's time, and most meshes have none: on 2 cores the 256^3 wedge ball at h <= 1 took 4.6 s, now
  // 2.7, the 100^3 head phantom 3.5 s, now 2.0 (same moves, same mesh); the 64^3 shells, whose every round crosses,
  // as before. Once a round tests clean the later ones are not tested: a crossing they make is undone at the end, and
  // its vertices lose every round's moves since then (and a triangle turned over 90 degrees since `safe` goes back
  // too).
  std::vector<glm::dvec3> safe = V;  // crossing-free: before the rounds, then after each round tested
  bool check_each_round = true, unchecked = false;
  for (int round = 0; round < options.rounds; ++round) {
    // Targets and their projections, in parallel from this round's positions.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nv), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t v = r.begin(); v < r.end(); ++v) {
        has[v] = 0;
        if (around[v].empty()) continue;
        const auto kind = E.features[vertex_feature[v]].kind;
        if (mesh.vertex_kind[v] != uint8_t(kind)) continue;  // a junction of the mesh off its feature's (extract.h)
        // An interface vertex's target is its shape target; a curve vertex has two, tried in turn at acceptance:
        // the shape target's shift along the curve from the midpoint of its curve neighbours (what most lifts the
        // triangles along the curve), and the midpoint itself (what evens the curve's spacing, and mends a
        // triangle of three curve vertices where the curve bends).
        std::array<glm::dvec3, 2> targets;
        int n = 0;
        if (kind == fields::FeatureKind::interface) {
          if (equilateral_target(uint32_t(v), targets[0])) n = 1;
        } else if (kind == fields::FeatureKind::triple_curve && along[v].size() == 2) {
          const glm::dvec3 mid = 0.5 * (V[along[v][0]] + V[along[v][1]]);
          const glm::dvec3 u = glm::normalize(V[along[v][1]] - V[along[v][0]]);
          glm::dvec3 shape;
          if (equilateral_target(uint32_t(v), shape)) targets[n++] = mid + u * glm::dot(shape - mid, u);
          targets[n++] = mid;
        }
        for (int i = 0; i < n; ++i) {
          const glm::dvec3 moved = V[v] + options.step * (targets[i] - V[v]);
          if (onto_feature(fields, E, vertex_feature[v], moved, V[v], proposal[v][has[v]])) ++has[v];
        }
      }
    });
    // Accepted one vertex at a time against the current positions: no triangle may flip, and the worst one around
    // the vertex may not get worse unless it stays at least kShapeFloor and the triangles' radius ratios gain in
    // sum; of a curve vertex's two proposals, the acceptable one with the larger sum. Vertices of one colour share
    // no triangle, so each colour's are checked in parallel (the same result on any number of threads).
    std::atomic<size_t> accepted{0}, refused{0};
    for (size_t c = 0; c + 1 < colour_begin.size(); ++c)
      tbb::parallel_for(tbb::blocked_range<size_t>(colour_begin[c], colour_begin[c + 1], 512),
                        [&](const tbb::blocked_range<size_t>& r) {
        std::vector<glm::dvec3> normals;
        size_t ok_here = 0, refused_here = 0;
        for (size_t k = r.begin(); k < r.end(); ++k) {
          const uint32_t v = by_colour[k];
          if (!has[v]) continue;
          const glm::dvec3 old = V[v];
          const auto before = shape_around(v);
          normals.clear();
          for (uint32_t t : around[v]) normals.push_back(normal_of(V[T[t][0]], V[T[t][1]], V[T[t][2]]));
          double best_sum = -1;  // of the best acceptable proposal, which is kept
          glm::dvec3 best = old;
          for (int p = 0; p < has[v]; ++p) {
            V[v] = proposal[v][p];
            const auto after = shape_around(v);
            bool ok = after[0] >= before[0] || (after[0] >= SmoothOptions::kShapeFloor && after[1] > before[1]);
            for (size_t i = 0; i < around[v].size() && ok; ++i) {
              const auto& tri = T[around[v][i]];
              ok = glm::dot(normal_of(V[tri[0]], V[tri[1]], V[tri[2]]), normals[i]) > 0;
            }
            if (ok && after[1] > best_sum) best_sum = after[1], best = V[v];
          }
          V[v] = best;
          ++(best_sum >= 0 ? ok_here : refused_here);
        }
        accepted += ok_here;
        refused += refused_here;
      });
    size_t moves = accepted;
    report.refused += refused;
    if (check_each_round) {
      const size_t undone = undo_crossings(safe, T, V);
      moves -= undone;
      report.refused += undone;
      check_each_round = undone > 0;
      safe = V;
    } else {
      unchecked = true;
    }
    report.moves += moves;
    ++report.rounds;
    if (moves == 0) break;
  }
  if (unchecked) {  // a vertex undone here loses the moves of every round since `safe`, counted as one
    const size_t undone = undo_crossings(safe, T, V);
    report.moves -= std::min(report.moves, undone);
    report.refused += undone;
  }
  return report;
}

double hashed_normal(uint64_t key) {
  auto mix = [](uint64_t x) {  // splitmix64's finaliser
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
  };
  const uint64_t a = mix(key), b = mix(key ^ 0x9e3779b97f4a7c15ull);
  const double u1 = (double(a >> 11) + 0.5) * 0x1p-53, u2 = double(b >> 11) * 0x1p-53;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

TetImproveReport improve_tets(std::vector<glm::dvec3>& P, const std::vector<std::array<uint32_t, 4>>& tets,
                              size_t fixed, double target_deg, double max_radius_edge, int passes) {
  TetImproveReport report;
  const double target = target_deg * M_PI / 180;
  // Every tet's smallest dihedral angle as its cosine (min_dihedral_cosine: no arc cosine; the angle never shrinks as
  // it grows), kept current as vertices move (one parallel pass, then only the tets of a moved vertex).
  std::vector<double> cosine(tets.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, tets.size()), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t) cosine[t] = min_dihedral_cosine(P, tets[t]);
  });
  // Whether tet t's angle is below the target, or at or above it (neither holds for a NaN): by its cosine where that
  // is clear (1e-9 either side of the target's cosine, far beyond the arc cosine's rounding), else by the angle.
  const double target_cosine = std::cos(M_PI - target);
  const bool banded = target >= 0 && target <= M_PI;
  auto below = [&](uint32_t t) {
    if (banded && cosine[t] < target_cosine - 1e-9) return true;
    if (banded && cosine[t] > target_cosine + 1e-9) return false;
    return dihedral_from_cosine(cosine[t]) < target;
  };
  // Below the target, or with no angle (a NaN: a flat tet's): a tet to mend.
  auto to_mend = [&](uint32_t t) { return std::isnan(cosine[t]) || below(t); };
  auto worst_angle = [&] {
    return cosine.empty() ? M_PI : dihedral_from_cosine(*std::min_element(cosine.begin(), cosine.end()));
  };
  const ElementsAround<4> around(P.size(), tets);
  std::vector<int8_t> sign(tets.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, tets.size()), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t) sign[t] = signed_volume6(P, tets[t]) > 0 ? 1 : -1;
  });
  report.min_dihedral_before = report.min_dihedral_after = worst_angle() * 180 / M_PI;
  // The smallest dihedral angle of v's tets (`mine`: all of them, in any order) with v at its current position, as
  // its cosine, or -2 (below every cosine) if one of them is inverted or over the radius-edge bound `limit`. A
  // candidate position is kept only if it beats the best so far, `floor`: once a tet's cosine is at most that, the
  // rest need not be looked at, and some value at most `floor` is returned. So a kept candidate's value does not
  // depend on the order. The tet that ended the test, or the worst one, goes first for the next candidate: it most
  // often ends that one too, and a low minimum early lets the other tets be passed over as certainly above it.
  auto quality_at = [&](std::vector<uint32_t>& mine, double limit, double floor) {
    double q = 1.0;
    size_t worst = 0;
    for (size_t i = 0; i < mine.size(); ++i) {
      const auto& k = tets[mine[i]];
      if (signed_volume6(P, k) * sign[mine[i]] <= 0) return -2.0;
      const double c = min_dihedral_cosine_unless_above(P[k[0]], P[k[1]], P[k[2]], P[k[3]], q);
      if (c < q) q = c, worst = i;
      if (q <= floor) {
        std::swap(mine[0], mine[i]);
        return q;
      }
      if (radius_edge_above(P[k[0]], P[k[1]], P[k[2]], P[k[3]], limit)) return -2.0;
    }
    std::swap(mine[0], mine[worst]);
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
  // A vertex's move: the candidates (its neighbours' centroid, then shrinking random steps around the best so far),
  // the best kept. Reads the positions of v's tets' other vertices and writes P[v] and the cosines of v's tets only.
  // The random steps are a hash of (pass, v's visit in it, v, draw): the same on any thread count.
  tbb::enumerable_thread_specific<std::vector<uint32_t>> scratch;
  auto move = [&](uint32_t v, int pass, uint8_t visit) {
    std::vector<uint32_t>& mine = scratch.local();
    const glm::dvec3 start = P[v];
    const double limit = std::max(max_radius_edge, radius_edge_at(v));  // never worse than the bound or now
    // v's tets, the smallest angle first (the candidates are near v: its worst tet is likely theirs).
    mine.assign(around[v].begin(), around[v].end());
    auto key = [&](uint32_t u) { return std::isnan(cosine[u]) ? -HUGE_VAL : cosine[u]; };  // NaN first, ordered
    std::sort(mine.begin(), mine.end(), [&](uint32_t a, uint32_t b) { return key(a) < key(b) || (key(a) == key(b) && a < b); });
    double best = quality_at(mine, limit, -HUGE_VAL);
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
    if (count == 0) return false;
    centroid /= double(count);
    edge /= double(count);
    // A candidate is kept where its angle (not only its cosine: neighbouring cosines often give one angle) beats
    // the best so far; any valid one beats an invalid start (-2).
    auto consider = [&](const glm::dvec3& at) {
      P[v] = at;
      const double q = quality_at(mine, limit, best);
      const bool better = best < -1 ? q >= -1 : q > best && dihedral_from_cosine(q) > dihedral_from_cosine(best);
      if (better) best = q, best_at = at;
    };
    consider(centroid);
    uint64_t draw = uint64_t(pass) << 56 ^ uint64_t(visit) << 48 ^ uint64_t(v) << 16;
    for (double step = 0.2 * edge; step > 0.01 * edge; step *= 0.5)
      for (int k = 0; k < 8; ++k, draw += 3)
        consider(best_at + step * glm::dvec3(hashed_normal(draw), hashed_normal(draw + 1), hashed_normal(draw + 2)) /
                               std::sqrt(3.0));
    P[v] = best_at;
    if (best_at == start) return false;
    for (uint32_t u : around[v]) cosine[u] = min_dihedral_cosine(P, tets[u]);
    return true;
  };
  constexpr uint32_t kNoRank = UINT32_MAX;
  constexpr uint8_t kMostVisits = 3;  // a vertex moves at most this often in a pass
  std::vector<uint32_t> rank(P.size(), kNoRank);  // a waiting vertex's place in its pass
  std::vector<uint8_t> visits(P.size());
  std::vector<uint32_t> waiting, next;
  std::vector<uint8_t> chosen, moved;
  for (int pass = 0; pass < passes; ++pass) {
    // The candidates: the free vertices of the tets to mend, in tet order.
    uint32_t ranked = 0;
    waiting.clear();
    std::fill(visits.begin(), visits.end(), uint8_t(0));
    for (uint32_t t = 0; t < tets.size(); ++t)
      if (to_mend(t))
        for (uint32_t v : tets[t])
          if (v >= fixed && rank[v] == kNoRank) {
            rank[v] = ranked++;
            waiting.push_back(v);
            visits[v] = 1;
          }
    size_t moves = 0;
    while (!waiting.empty()) {
      // A round moves every waiting candidate that outranks each other one sharing a tet with it (no two movers
      // share a tet, so their moves are independent: the same on any thread count), where a tet of it is still to
      // mend.
      chosen.assign(waiting.size(), 0);
      moved.assign(waiting.size(), 0);
      tbb::parallel_for(size_t(0), waiting.size(), [&](size_t i) {
        const uint32_t v = waiting[i];
        for (uint32_t u : around[v])
          for (uint32_t w : tets[u])
            if (w != v && rank[w] < rank[v]) return;
        chosen[i] = 1;
        bool any = false;
        for (uint32_t u : around[v]) any = any || to_mend(u);
        if (any) moved[i] = move(v, pass, visits[v]);
      });
      // The rest wait for the next round; after them, the free vertices of a moved vertex's tets still to mend
      // (kMostVisits each in the pass), in order.
      next.clear();
      for (size_t i = 0; i < waiting.size(); ++i)
        if (chosen[i]) rank[waiting[i]] = kNoRank;
        else next.push_back(waiting[i]);
      for (size_t i = 0; i < waiting.size(); ++i) {
        if (!moved[i]) continue;
        ++moves;
        for (uint32_t u : around[waiting[i]]) {
          if (!to_mend(u)) continue;
          for (uint32_t w : tets[u])
            if (w >= fixed && rank[w] == kNoRank && visits[w] < kMostVisits) {
              rank[w] = ranked++;
              ++visits[w];
              next.push_back(w);
            }
        }
      }
      waiting.swap(next);
    }
    report.moves += moves;
    if (moves == 0) break;
  }
  report.min_dihedral_after = worst_angle() * 180 / M_PI;
  return report;
}

SliverSplitReport split_slivers(std::vector<glm::dvec3>& P, std::vector<std::array<uint32_t, 4>>& tets,
                                std::vector<int>& region, const std::vector<std::array<uint32_t, 3>>& kept,
                                double target_deg, double max_radius_edge, int max_rings, bool remove_edges) {
  SliverSplitReport report;
  const double target = target_deg * M_PI / 180;
  constexpr uint32_t dead = UINT32_MAX;
  auto orient = [&](const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d) {
    return glm::dot(b - a, glm::cross(c - a, d - a));
  };
  std::vector<uint8_t> below(tets.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, tets.size()), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t) below[t] = min_dihedral(P, tets[t]) < target;
  });
  std::vector<uint32_t> bad;
  for (uint32_t t = 0; t < tets.size(); ++t)
    if (below[t]) bad.push_back(t);
  if (bad.empty()) return report;  // nothing to do: no incidence tables
  // Neighbours across faces and kept faces are found from the elements around a face's first vertex.
  ElementsAround<4> around(P.size(), tets);
  const ElementsAround<3> kept_around(P.size(), kept);
  auto is_kept = [&](const std::array<uint32_t, 3>& f) { return has_triangle(kept_around, kept, f); };
  auto link = [&](uint32_t t) {
    for (uint32_t v : tets[t]) around.add(v, t);
  };
  auto unlink = [&](uint32_t t) {
    for (uint32_t v : tets[t]) around.remove(v, t);
  };
  auto neighbour = [&](uint32_t t, int i) { return tet_across(around, tets, t, i); };

  const bool had_regions = !region.empty();
  if (!had_regions) region.assign(tets.size(), 0);
  // Replaces the tets in `old_slots` by `made`, all of region r: the old slots are reused first, the rest appended,
  // and slots left over are marked dead (dropped at the end).
  auto replace = [&](const std::vector<uint32_t>& old_slots, const std::vector<std::array<uint32_t, 4>>& made, int r) {
    for (uint32_t t : old_slots) unlink(t);
    for (size_t i = 0; i < made.size(); ++i) {
      uint32_t slot;
      if (i < old_slots.size()) {
        slot = old_slots[i];
        tets[slot] = made[i];
      } else {
        slot = uint32_t(tets.size());
        tets.push_back(made[i]);
        region.push_back(r);
      }
      region[slot] = r;
      link(slot);
    }
    for (size_t i = made.size(); i < old_slots.size(); ++i) tets[old_slots[i]] = {dead, dead, dead, dead};
  };
  // Edge removal: the n tets around an edge (a, b) of the sliver (all of one region, no kept face among the n faces
  // on the edge) become the 2n - 4 tets joining a and b to a fan triangulation of the ring of their other vertices.
  // A sliver's two long edges carry its near-180-degree dihedral angles; removing one removes the sliver with no new
  // vertex. The best of every edge and fan is taken when its smallest dihedral angle beats the old tets' and no new
  // tet goes over the radius-edge limit (as the cavities below). Returns whether the mesh changed.
  auto remove_edge = [&](uint32_t start) {
    const auto k = tets[start];
    const bool positive = orient(P[k[0]], P[k[1]], P[k[2]], P[k[3]]) > 0;
    double best = -1;
    std::vector<uint32_t> best_ring_tets;
    std::vector<std::array<uint32_t, 4>> best_new;
    for (int ea = 0; ea < 4; ++ea)
      for (int eb = ea + 1; eb < 4; ++eb) {
        const uint32_t a = k[size_t(ea)], b = k[size_t(eb)];
        // Walk around the edge: ring vertices p_0, p_1, ... with tets (a, b, p_i, p_i+1), crossing the faces
        // (a, b, p_i+1) until the walk is back at the sliver.
        uint32_t others[2];
        int found = 0;
        for (uint32_t v : k)
          if (v != a && v != b) others[found++] = v;
        std::vector<uint32_t> ring{others[0]}, ring_tets;
        uint32_t prev = others[0], cur = others[1], t = start;
        bool closed = false;
        for (int step = 0; step < 8; ++step) {
          if (region[t] != region[start]) break;
          ring_tets.push_back(t);
          const auto& q = tets[t];
          int opposite = 0;
          while (opposite < 4 && q[size_t(opposite)] != prev) ++opposite;
          if (opposite == 4 || is_kept(face_opposite(q, opposite))) break;
          const uint32_t u = neighbour(t, opposite);
          if (u == dead) break;
          if (u == start) {
            closed = cur == others[0];
            break;
          }
          ring.push_back(cur);
          uint32_t next = dead;
          for (uint32_t v : tets[u])
            if (v != a && v != b && v != cur) next = v;
          if (next == dead) break;
          prev = cur;
          cur = next;
          t = u;
        }
        const size_t n = ring.size();
        if (!closed || n < 3 || n > 7) continue;
        double old_worst = M_PI, old_ratio = 0;
        for (uint32_t r : ring_tets) {
          const auto& q = tets[r];
          old_worst = std::min(old_worst, min_dihedral(P, q));
          old_ratio = std::max(old_ratio, radius_edge_ratio(P[q[0]], P[q[1]], P[q[2]], P[q[3]]));
        }
        const double limit = std::max(1.5 * max_radius_edge, old_ratio);
        for (size_t apex = 0; apex < n; ++apex) {  // fan from ring vertex `apex`
          std::vector<std::array<uint32_t, 4>> made;
          double worst = M_PI;
          bool ok = true;
          for (size_t i = 1; i + 1 < n && ok; ++i) {
            const uint32_t p0 = ring[apex], p1 = ring[(apex + i) % n], p2 = ring[(apex + i + 1) % n];
            for (uint32_t end : {a, b}) {
              std::array<uint32_t, 4> q{p0, p1, p2, end};
              const double o = orient(P[q[0]], P[q[1]], P[q[2]], P[q[3]]);
              if ((o > 0) != positive) std::swap(q[1], q[2]);
              const double vol = std::fabs(o);
              const double e = glm::length(P[p1] - P[p0]) + glm::length(P[p2] - P[p1]) + glm::length(P[end] - P[p0]);
              if (vol <= 1e-9 * e * e * e / 27 || radius_edge_ratio(P[q[0]], P[q[1]], P[q[2]], P[q[3]]) > limit) {
                ok = false;
                break;
              }
              worst = std::min(worst, min_dihedral(P, q));
              made.push_back(q);
            }
          }
          if (!ok || worst <= old_worst + 1e-3 || worst <= best) continue;
          // The new tets must fill exactly the old ones (a and b on either side of every fan triangle).
          double v_old = 0, v_new = 0;
          for (uint32_t r : ring_tets) v_old += std::fabs(orient(P[tets[r][0]], P[tets[r][1]], P[tets[r][2]], P[tets[r][3]]));
          for (const auto& q : made) v_new += std::fabs(orient(P[q[0]], P[q[1]], P[q[2]], P[q[3]]));
          if (std::fabs(v_new - v_old) > 1e-9 * v_old) continue;
          best = worst;
          best_ring_tets = ring_tets;
          best_new = made;
        }
      }
    if (best < 0) return false;
    replace(best_ring_tets, best_new, region[start]);
    return true;
  };
  std::mt19937 rng(54321);
  std::normal_distribution<double> n01;
  for (uint32_t start : bad) {
    if (tets[start][0] == dead || min_dihedral(P, tets[start]) >= target) continue;  // replaced or fixed meanwhile
    const bool positive = orient(P[tets[start][0]], P[tets[start][1]], P[tets[start][2]], P[tets[start][3]]) > 0;
    if (remove_edges && remove_edge(start)) {
      ++report.flips;
      continue;
    }
    std::vector<uint32_t> cavity{start};
    std::set<uint32_t> in_cavity{start};
    bool done = false;
    for (int ring = 0; ring <= max_rings && !done; ++ring) {
      if (ring > 0) {  // one more ring of same-region neighbours, not across kept faces
        const std::vector<uint32_t> current = cavity;
        for (uint32_t t : current)
          for (int i = 0; i < 4; ++i) {
            const uint32_t u = neighbour(t, i);
            if (u == dead || in_cavity.count(u) || region[u] != region[start]) continue;
            if (is_kept(face_opposite(tets[t], i))) continue;
            cavity.push_back(u);
            in_cavity.insert(u);
          }
        if (cavity.size() == current.size()) break;
      }
      // The cavity's boundary: faces of its tets whose other side is not in it, each with the inner side's sign.
      struct Boundary {
        std::array<uint32_t, 3> f;
        double sign;
      };
      std::vector<Boundary> boundary;
      std::set<uint32_t> cavity_vertices, boundary_vertices;
      double old_worst = M_PI, old_ratio = 0, volume = 0;
      glm::dvec3 centroid(0.0);
      for (uint32_t t : cavity) {
        const auto& k = tets[t];
        old_worst = std::min(old_worst, min_dihedral(P, k));
        old_ratio = std::max(old_ratio, radius_edge_ratio(P[k[0]], P[k[1]], P[k[2]], P[k[3]]));
        volume += std::fabs(orient(P[k[0]], P[k[1]], P[k[2]], P[k[3]]));
        for (uint32_t v : k) cavity_vertices.insert(v);
        for (int i = 0; i < 4; ++i) {
          const uint32_t u = neighbour(t, i);
          if (u != dead && in_cavity.count(u)) continue;
          const auto f = face_opposite(k, i);
          boundary.push_back({f, orient(P[f[0]], P[f[1]], P[f[2]], P[k[size_t(i)]]) > 0 ? 1.0 : -1.0});
          for (uint32_t v : f) boundary_vertices.insert(v);
        }
      }
      if (boundary_vertices.size() != cavity_vertices.size()) continue;  // a vertex inside the cavity would be lost
      for (uint32_t v : cavity_vertices) centroid += P[v];
      centroid /= double(cavity_vertices.size());
      double edge = 0;
      for (uint32_t v : cavity_vertices) edge += glm::length(P[v] - centroid);
      edge /= double(cavity_vertices.size());
      // The cone's tets may go half again over the radius-edge bound: a sliver (ratio often near 1) is far worse for
      // a solver than a tet of ratio 2 with good angles.
      const double limit = std::max(1.5 * max_radius_edge, old_ratio);
      // Smallest dihedral angle of the cone from x, or -1 where a new tet is inverted, flat or over the bound.
      auto cone_quality = [&](const glm::dvec3& x) {
        double q = M_PI;
        for (const auto& b : boundary) {
          const glm::dvec3 &a = P[b.f[0]], &c = P[b.f[1]], &d = P[b.f[2]];
          if (orient(a, c, d, x) * b.sign <= 1e-12 * edge * edge * edge) return -1.0;
          if (radius_edge_ratio(a, c, d, x) > limit) return -1.0;
          q = std::min(q, min_dihedral(a, c, d, x));
        }
        return q;
      };
      double best = -1;
      glm::dvec3 best_at = centroid;
      auto consider = [&](const glm::dvec3& x) {
        const double q = cone_quality(x);
        if (q > best) best = q, best_at = x;
      };
      consider(centroid);
      for (uint32_t t : cavity) {
        const auto& k = tets[t];
        consider(0.25 * (P[k[0]] + P[k[1]] + P[k[2]] + P[k[3]]));
      }
      for (int k = 0; k < 64; ++k) consider(centroid + 0.5 * edge * glm::dvec3(n01(rng), n01(rng), n01(rng)) / std::sqrt(3.0));
      if (best < 0) continue;
      for (double step = 0.2 * edge; step > 0.005 * edge; step *= 0.6)
        for (int k = 0; k < 12; ++k) consider(best_at + step * glm::dvec3(n01(rng), n01(rng), n01(rng)) / std::sqrt(3.0));
      if (best <= old_worst + 1e-3) continue;
      double new_volume = 0;
      for (const auto& b : boundary) new_volume += std::fabs(orient(P[b.f[0]], P[b.f[1]], P[b.f[2]], best_at));
      if (std::fabs(new_volume - volume) > 1e-9 * std::max(volume, 1e-30)) continue;  // not a star around the point
      // Replace: the first cavity slots are reused, the rest appended.
      const uint32_t v = uint32_t(P.size());
      P.push_back(best_at);
      std::vector<std::array<uint32_t, 4>> cone;
      for (const auto& b : boundary)  // same orientation as the tets replaced
        cone.push_back((b.sign > 0) == positive ? std::array<uint32_t, 4>{b.f[0], b.f[1], b.f[2], v}
                                                : std::array<uint32_t, 4>{b.f[0], b.f[2], b.f[1], v});
      replace(cavity, cone, region[start]);
      ++report.inserted;
      done = true;
    }
    if (!done) ++report.failed;
  }
  keep_tets(tets, region, [&](size_t t) { return tets[t][0] != dead; });  // drop the emptied slots
  if (!had_regions) region.clear();
  return report;
}

}  // namespace cpmesh::mesh
