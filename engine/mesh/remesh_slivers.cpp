#include "mesh/remesh_slivers.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "host/disjoint_sets.h"
#include "mesh/elements_around.h"
#include "mesh/face_key.h"
#include "mesh/quality.h"
#include "mesh/smooth.h"

namespace cpmesh::mesh {

namespace {

constexpr uint32_t kNone = UINT32_MAX;

struct Cavity {
  std::vector<uint32_t> tets;
  std::vector<std::array<uint32_t, 3>> boundary;
  int region = 0;
  double volume = 0, worst = 0;
  size_t below = 0;  // tets under the dihedral bound
  glm::dvec3 seed{0.0};
};

}  // namespace

SliverRemeshReport remesh_slivers(std::vector<glm::dvec3>& P, std::vector<std::array<uint32_t, 4>>& tets,
                                  std::vector<int>& region, const std::vector<std::array<uint32_t, 3>>& kept,
                                  size_t fixed, const QualityOptions& options, int rings, size_t batch,
                                  const std::function<void(size_t cavities)>& before_run) {
  SliverRemeshReport report;
  const double target = options.min_dihedral * M_PI / 180;
  std::vector<uint8_t> below(tets.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, tets.size()), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t) below[t] = min_dihedral(P, tets[t]) < target;
  });
  std::vector<uint32_t> bad;
  for (uint32_t t = 0; t < tets.size(); ++t)
    if (below[t]) bad.push_back(t);
  report.slivers = bad.size();
  if (bad.empty()) return report;
  const bool had_regions = !region.empty();
  if (!had_regions) region.assign(tets.size(), 0);

  const ElementsAround<4> around(P.size(), tets);
  const ElementsAround<3> kept_around(P.size(), kept);
  auto neighbour = [&](uint32_t t, int i) { return tet_across(around, tets, t, i); };
  auto is_kept = [&](uint32_t t, int i) { return has_triangle(kept_around, kept, face_opposite(tets[t], i)); };
  // Across face i of t, within the region and not through a kept face: the neighbour, else kNone.
  auto step = [&](uint32_t t, int i) {
    const uint32_t u = neighbour(t, i);
    if (u == kNone || region[u] != region[t] || is_kept(t, i)) return kNone;
    return u;
  };

  // Each bad tet's cavity; overlapping ones merged (union-find over the bad tets, through the tets they claim).
  DisjointSets sets(bad.size());
  std::unordered_map<uint32_t, uint32_t> claimed;  // tet -> a bad tet's index whose cavity holds it
  for (uint32_t b = 0; b < bad.size(); ++b) {
    const uint32_t start = bad[b];
    const auto& k = tets[start];
    std::vector<uint32_t> cavity{start};
    std::unordered_set<uint32_t> in{start};
    // The tets sharing a vertex with the bad one, reached across faces; then rings of face neighbours.
    for (size_t q = 0; q < cavity.size(); ++q)
      for (int i = 0; i < 4; ++i) {
        const uint32_t u = step(cavity[q], i);
        if (u == kNone || in.count(u)) continue;
        if (!std::any_of(k.begin(), k.end(), [&](uint32_t v) { return has_vertex(tets[u], v); })) continue;
        in.insert(u);
        cavity.push_back(u);
      }
    for (int ring = 0; ring < rings; ++ring) {
      const size_t n = cavity.size();
      for (size_t q = 0; q < n; ++q)
        for (int i = 0; i < 4; ++i) {
          const uint32_t u = step(cavity[q], i);
          if (u != kNone && in.insert(u).second) cavity.push_back(u);
        }
    }
    for (uint32_t t : cavity) {
      const auto [it, fresh] = claimed.try_emplace(t, b);
      if (!fresh) sets.join(b, it->second);
    }
  }
  // The merged cavities, in the order of their first bad tet; each tet's cavity.
  std::unordered_map<uint32_t, uint32_t> cavity_of_root;
  std::vector<Cavity> cavities;
  std::unordered_map<uint32_t, uint32_t> cavity_of_tet;
  cavity_of_tet.reserve(claimed.size());
  for (uint32_t b = 0; b < bad.size(); ++b) {
    const auto [it, fresh] = cavity_of_root.try_emplace(sets.find(b), uint32_t(cavities.size()));
    if (fresh) cavities.push_back({{}, {}, region[bad[b]]});
  }
  {
    std::vector<std::pair<uint32_t, uint32_t>> members(claimed.begin(), claimed.end());
    std::sort(members.begin(), members.end());  // tet order: the same cavities whatever the hash map's order
    for (const auto& [t, b] : members) {
      const uint32_t c = cavity_of_root[sets.find(b)];
      cavities[c].tets.push_back(t);
      cavity_of_tet.emplace(t, c);
    }
  }
  report.cavities = cavities.size();

  // Boundary faces, the old volume, worst angle and slivers, and the best-shaped tet (its centroid seeds the cavity's
  // region). A cavity that would drop a fixed vertex or a kept face (one between two of its tets) is left alone.
  std::vector<uint8_t> usable(cavities.size(), 1);
  for (uint32_t c = 0; c < cavities.size(); ++c) {
    Cavity& cav = cavities[c];
    std::unordered_set<uint32_t> on_boundary, all;
    cav.worst = M_PI;
    double best = -1;
    for (uint32_t t : cav.tets) {
      const auto& k = tets[t];
      cav.volume += tet_volume(P[k[0]], P[k[1]], P[k[2]], P[k[3]]);
      const double angle = min_dihedral(P, k);
      cav.worst = std::min(cav.worst, angle);
      cav.below += angle < target;
      if (angle > best) best = angle, cav.seed = (P[k[0]] + P[k[1]] + P[k[2]] + P[k[3]]) / 4.0;
      for (uint32_t v : k) all.insert(v);
      for (int i = 0; i < 4; ++i) {
        const uint32_t u = neighbour(t, i);
        if (u != kNone) {
          const auto it = cavity_of_tet.find(u);
          if (it != cavity_of_tet.end() && it->second == c) {
            if (is_kept(t, i)) usable[c] = 0;
            continue;
          }
        }
        const auto f = face_opposite(k, i);
        cav.boundary.push_back(f);
        for (uint32_t v : f) on_boundary.insert(v);
      }
    }
    for (uint32_t v : all)
      if (v < fixed && !on_boundary.count(v)) usable[c] = 0;
  }

  // TetGen over the cavities given (their boundary faces, each face once; one seed per cavity, attribute c + 1).
  // Returns, per cavity given, its new tets in the caller's numbering (new points appended to P only on success).
  auto remesh = [&](const std::vector<uint32_t>& which, std::vector<std::vector<std::array<uint32_t, 4>>>& made,
                    std::vector<glm::dvec3>& new_points) {
    std::unordered_map<uint32_t, uint32_t> local;
    std::vector<uint32_t> global;
    std::vector<glm::dvec3> local_points;
    std::vector<std::array<uint32_t, 3>> faces;
    std::unordered_set<FaceKey, FaceKeyHash> seen;
    std::vector<Region> seeds;
    for (uint32_t c : which) {
      for (const auto& f : cavities[c].boundary) {
        if (!seen.insert(FaceKey(f)).second) continue;
        std::array<uint32_t, 3> g{};
        for (int a = 0; a < 3; ++a) {
          const auto [it, fresh] = local.try_emplace(f[size_t(a)], uint32_t(global.size()));
          if (fresh) {
            global.push_back(f[size_t(a)]);
            local_points.push_back(P[f[size_t(a)]]);
          }
          g[size_t(a)] = it->second;
        }
        faces.push_back(g);
      }
      seeds.push_back({cavities[c].seed, int(c) + 1});
    }
    QualityOptions o = options;
    o.keep_surface = true;
    o.dihedral_in_tetgen = true;
    const Tets T = constrained_quality(local_points, faces, {}, seeds, o);
    made.assign(which.size(), {});
    std::unordered_map<uint32_t, size_t> slot;
    for (size_t i = 0; i < which.size(); ++i) slot[which[i]] = i;
    new_points.assign(T.points.begin() + std::ptrdiff_t(local_points.size()), T.points.end());
    for (size_t t = 0; t < T.tets.size(); ++t) {
      // A pocket the cavities enclose but do not hold (other tets they surround) is meshed too, under an attribute
      // TetGen numbers past the seeds' (no cavity of this run).
      const auto it = slot.find(uint32_t(T.region[t] - 1));
      if (it == slot.end()) continue;
      std::array<uint32_t, 4> q{};
      for (int a = 0; a < 4; ++a) {
        const uint32_t v = T.tets[t][size_t(a)];
        q[size_t(a)] = v < global.size() ? global[v] : uint32_t(P.size() + (v - global.size()));
      }
      made[it->second].push_back(q);
    }
  };
  std::vector<uint32_t> todo;
  for (uint32_t c = 0; c < cavities.size(); ++c)
    if (usable[c]) todo.push_back(c);

  std::vector<std::vector<std::array<uint32_t, 4>>> made(cavities.size());
  std::vector<uint8_t> has_mesh(cavities.size(), 0);
  std::vector<glm::dvec3> extra;  // new points, numbered from P.size()
  auto run = [&](const std::vector<uint32_t>& which) {
    std::vector<std::vector<std::array<uint32_t, 4>>> m;
    std::vector<glm::dvec3> np;
    try {
      if (before_run) before_run(which.size());
      remesh(which, m, np);
    } catch (const std::exception&) {
      ++report.tetgen_failures;
      return false;
    }
    // Renumber this run's new points after those of earlier runs.
    const auto shift = uint32_t(extra.size());
    for (size_t i = 0; i < which.size(); ++i) {
      for (auto& q : m[i])
        for (auto& v : q) v = v < P.size() ? v : v + shift;
      made[which[i]] = std::move(m[i]);
      has_mesh[which[i]] = 1;
    }
    extra.insert(extra.end(), np.begin(), np.end());
    return true;
  };
  // One run for all (or per `batch` cavities); where TetGen gives up, halves, down to single cavities.
  std::function<void(const std::vector<uint32_t>&)> attempt = [&](const std::vector<uint32_t>& which) {
    if (which.empty() || run(which) || which.size() == 1) return;
    const auto middle = which.begin() + std::ptrdiff_t(which.size() / 2);
    attempt({which.begin(), middle});
    attempt({middle, which.end()});
  };
  const size_t per_run = batch > 0 ? batch : std::max<size_t>(todo.size(), 1);
  for (size_t i = 0; i < todo.size(); i += per_run)
    attempt({todo.begin() + std::ptrdiff_t(i), todo.begin() + std::ptrdiff_t(std::min(todo.size(), i + per_run))});

  // Each new mesh gets the vertex moves the old tets had (improve_tets: its new points move, the cavity's boundary
  // stays), then is kept where it fills the cavity, raises its worst angle and leaves no more slivers (the new points
  // of one that is not are left unused and dropped below).
  const size_t first_new = P.size();
  P.insert(P.end(), extra.begin(), extra.end());
  tbb::parallel_for(size_t(0), cavities.size(), [&](size_t c) {
    if (!has_mesh[c] || made[c].empty()) return;
    // The new tets' own boundary must be the cavity's, face for face (-Y puts no point on it); then every new point
    // is inside one cavity, and the cavities' moves below touch disjoint points.
    std::unordered_map<FaceKey, int, FaceKeyHash> uses;
    for (const auto& q : made[c])
      for (int i = 0; i < 4; ++i) ++uses[FaceKey(face_opposite(q, i))];
    size_t hull = 0;
    for (const auto& [f, n] : uses) hull += n == 1;
    bool same = hull == cavities[c].boundary.size();
    for (const auto& f : cavities[c].boundary) {
      const auto it = uses.find(FaceKey(f));
      same = same && it != uses.end() && it->second == 1;
    }
    if (!same) {
      has_mesh[c] = 0;
      return;
    }
    std::unordered_map<uint32_t, uint32_t> local;
    std::vector<uint32_t> global;
    std::vector<glm::dvec3> local_points;
    for (const bool boundary : {true, false})  // the cavity's boundary vertices first: they stay
      for (const auto& q : made[c])
        for (uint32_t v : q)
          if ((v < first_new) == boundary && local.emplace(v, uint32_t(global.size())).second) {
            global.push_back(v);
            local_points.push_back(P[v]);
          }
    size_t fixed_here = 0;
    while (fixed_here < global.size() && global[fixed_here] < first_new) ++fixed_here;
    std::vector<std::array<uint32_t, 4>> local_tets = made[c];
    for (auto& q : local_tets)
      for (auto& v : q) v = local.at(v);
    improve_tets(local_points, local_tets, fixed_here, options.min_dihedral, options.max_radius_edge);
    for (size_t i = fixed_here; i < global.size(); ++i) P[global[i]] = local_points[i];
  });
  const std::vector<glm::dvec3>& all = P;
  std::vector<uint8_t> dead(tets.size(), 0);
  const size_t old_count = tets.size();
  for (uint32_t c = 0; c < cavities.size(); ++c) {
    if (!has_mesh[c] || made[c].empty()) continue;
    double volume = 0, worst = M_PI;
    size_t slivers = 0;
    for (const auto& q : made[c]) {
      volume += tet_volume(all[q[0]], all[q[1]], all[q[2]], all[q[3]]);
      const double angle = min_dihedral(all, q);
      worst = std::min(worst, angle);
      slivers += angle < target;
    }
    if (std::fabs(volume - cavities[c].volume) > 1e-9 * cavities[c].volume || worst <= cavities[c].worst + 1e-3 ||
        slivers > cavities[c].below)
      continue;
    // The same handedness as the tets they replace.
    const auto& k0 = tets[cavities[c].tets.front()];
    const bool positive = signed_volume6(P, k0) > 0;
    for (uint32_t t : cavities[c].tets) dead[t] = 1;
    for (auto q : made[c]) {
      const bool p = signed_volume6(all, q) > 0;
      if (p != positive) std::swap(q[1], q[2]);
      tets.push_back(q);
      region.push_back(cavities[c].region);
    }
    ++report.remeshed;
  }
  if (report.remeshed == 0) {  // nothing changed: the appended points go again
    P.resize(P.size() - extra.size());
    if (!had_regions) region.clear();
    return report;
  }
  // Drop the replaced tets, then the points >= fixed that no tet uses.
  keep_tets(tets, region, [&](size_t t) { return t >= old_count || !dead[t]; });
  report.points_removed = remove_unused_points(P, tets, fixed);
  if (!had_regions) region.clear();
  return report;
}

size_t remove_unused_points(std::vector<glm::dvec3>& P, std::vector<std::array<uint32_t, 4>>& tets, size_t fixed) {
  std::vector<uint8_t> used(P.size(), 0);
  for (const auto& q : tets)
    for (uint32_t v : q) used[v] = 1;
  std::vector<uint32_t> index(P.size());
  size_t n = 0;
  for (size_t v = 0; v < P.size(); ++v) {
    if (v >= fixed && !used[v]) continue;
    index[v] = uint32_t(n);
    P[n++] = P[v];
  }
  const size_t removed = P.size() - n;
  P.resize(n);
  if (removed > 0)
    for (auto& q : tets)
      for (auto& v : q) v = index[v];
  return removed;
}

}  // namespace cpmesh::mesh
