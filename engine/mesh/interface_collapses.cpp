#include "mesh/interface_collapses.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "fields/closest_point_embedding.h"
#include "mesh/elements_around.h"
#include "mesh/interface_flips.h"
#include "mesh/quality.h"

namespace cpmesh::mesh {
namespace {

using Triangle = std::array<uint32_t, 3>;
using Pair = std::array<uint16_t, 2>;
using fields::FeatureKind;

struct Collapse {
  uint32_t from = 0, to = 0;  // b, a
  double gain = 0;
  std::vector<uint32_t> gone;     // the triangles on the edge
  std::vector<uint32_t> changed;  // b's other triangles, which take a
};

Triangle with_vertex(Triangle t, uint32_t from, uint32_t to) {
  for (uint32_t& v : t)
    if (v == from) v = to;
  return t;
}

// The materials each vertex's triangles meet, ascending and distinct.
std::vector<std::vector<uint16_t>> met_materials(const InterfaceMesh& m) {
  std::vector<std::vector<uint16_t>> met(m.vertices.size());
  for (size_t t = 0; t < m.triangles.size(); ++t)
    for (uint32_t v : m.triangles[t]) met[v].insert(met[v].end(), m.pair[t].begin(), m.pair[t].end());
  for (auto& s : met) {
    std::sort(s.begin(), s.end());
    s.erase(std::unique(s.begin(), s.end()), s.end());
  }
  return met;
}

// The pairs of the triangles on each edge (a, x) of `star` (triangles around a), grouped by x.
std::vector<std::pair<uint32_t, Pair>> edges_at(uint32_t a, const std::vector<std::pair<Triangle, Pair>>& star) {
  std::vector<std::pair<uint32_t, Pair>> out;
  for (const auto& [t, p] : star)
    for (uint32_t x : t)
      if (x != a) out.push_back({x, p});
  std::sort(out.begin(), out.end());
  return out;
}

// Every edge at a is an inner edge of one interface or a curve edge (interface_collapses.h).
bool edges_valid(const std::vector<std::pair<uint32_t, Pair>>& edges) {
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j].first == edges[i].first) ++j;
    const size_t n = j - i;
    if (n < 2) return false;
    for (size_t k = i + 1; k < j; ++k)
      if ((edges[k].second == edges[k - 1].second) != (n == 2)) return false;  // sorted: repeats are adjacent
    i = j;
  }
  return true;
}

// The fans of a's triangles of interface p: its triangles joined across the edges at a they share.
size_t fans(uint32_t a, const Pair& p, const std::vector<std::pair<Triangle, Pair>>& star) {
  std::vector<uint32_t> of;  // the triangles of p, by their index in star
  for (uint32_t i = 0; i < star.size(); ++i)
    if (star[i].second == p) of.push_back(i);
  std::vector<uint32_t> root(of.size());
  std::iota(root.begin(), root.end(), 0);
  auto find = [&](uint32_t i) {
    while (root[i] != i) i = root[i] = root[root[i]];
    return i;
  };
  size_t count = of.size();
  for (size_t i = 0; i < of.size(); ++i)
    for (size_t j = i + 1; j < of.size(); ++j) {
      bool shared = false;
      for (uint32_t x : star[of[i]].first)
        shared = shared || (x != a && has_vertex(star[of[j]].first, x));
      const uint32_t ri = find(uint32_t(i)), rj = find(uint32_t(j));
      if (shared && ri != rj) root[ri] = rj, --count;
    }
  return count;
}

// Each interface's triangles in `star` (those around a) form one fan at a.
bool one_fan_each(uint32_t a, const std::vector<std::pair<Triangle, Pair>>& star) {
  std::vector<Pair> pairs;
  for (const auto& e : star) pairs.push_back(e.second);
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return std::all_of(pairs.begin(), pairs.end(), [&](const Pair& p) { return fans(a, p, star) == 1; });
}

// The link condition inside interface p (Dey et al.'s, with the interface's boundary coned to a dummy vertex): the
// vertices and edges the links of a and b share are those of the link of edge (a, b), so the interface keeps its
// topology (a patch of one triangle between three curves is not collapsed away).
bool link_condition(const InterfaceMesh& m, const ElementsAround<3>& around, const Pair& p, uint32_t a, uint32_t b) {
  constexpr uint32_t kCone = UINT32_MAX;
  struct Link {
    std::vector<uint32_t> vertices;
    std::vector<std::array<uint32_t, 2>> edges;
  };
  auto link_of = [&](uint32_t v) {
    Link l;
    std::vector<uint32_t> ends;  // of v's edges in p, each once per triangle
    for (uint32_t t : around[v]) {
      if (m.pair[t] != p) continue;
      std::array<uint32_t, 2> e{};
      int n = 0;
      for (uint32_t x : m.triangles[t])
        if (x != v) e[size_t(n++)] = x;
      l.edges.push_back({std::min(e[0], e[1]), std::max(e[0], e[1])});
      ends.insert(ends.end(), e.begin(), e.end());
    }
    std::sort(ends.begin(), ends.end());
    bool boundary = false;
    for (size_t i = 0; i < ends.size();) {
      size_t j = i;
      while (j < ends.size() && ends[j] == ends[i]) ++j;
      l.vertices.push_back(ends[i]);
      if (j - i == 1) l.edges.push_back({ends[i], kCone}), boundary = true;  // a boundary edge of p
      i = j;
    }
    if (boundary) l.vertices.push_back(kCone);
    std::sort(l.edges.begin(), l.edges.end());
    return l;
  };
  const Link la = link_of(a), lb = link_of(b);
  std::vector<uint32_t> shared, of_edge;
  std::set_intersection(la.vertices.begin(), la.vertices.end(), lb.vertices.begin(), lb.vertices.end(),
                        std::back_inserter(shared));
  std::vector<std::array<uint32_t, 2>> shared_edges;
  std::set_intersection(la.edges.begin(), la.edges.end(), lb.edges.begin(), lb.edges.end(),
                        std::back_inserter(shared_edges));
  for (uint32_t t : around[a])
    if (m.pair[t] == p && has_vertex(m.triangles[t], b))
      for (uint32_t x : m.triangles[t])
        if (x != a && x != b) of_edge.push_back(x);
  if (of_edge.size() == 1) of_edge.push_back(kCone);  // a boundary edge of p
  std::sort(of_edge.begin(), of_edge.end());
  return shared_edges.empty() && shared == of_edge;
}

// The edge (b, a) as the feature rules of interface_collapses.h allow it: its triangles, or none. (The topology rules,
// dearer, come once the collapse is known to gain.)
std::vector<uint32_t> edge_triangles(const InterfaceMesh& m, const ElementsAround<3>& around,
                                     const std::vector<std::vector<uint16_t>>& met, uint32_t b, uint32_t a) {
  const auto kb = FeatureKind(m.vertex_kind[b]);
  if (kb == FeatureKind::quadruple_point || m.vertex_kind[a] > m.vertex_kind[b]) return {};
  if (met[b].size() != (kb == FeatureKind::interface ? 2u : 3u)) return {};
  if (!std::includes(met[a].begin(), met[a].end(), met[b].begin(), met[b].end())) return {};
  std::vector<uint32_t> on;
  for (uint32_t t : around[b])
    if (has_vertex(m.triangles[t], a)) on.push_back(t);
  std::vector<Pair> pairs;
  for (uint32_t t : on) pairs.push_back(m.pair[t]);
  std::sort(pairs.begin(), pairs.end());
  const bool distinct = std::adjacent_find(pairs.begin(), pairs.end()) == pairs.end();
  const bool inner = on.size() == 2 && pairs[0] == pairs[1];
  const bool curve = on.size() == 3 && distinct;
  return (kb == FeatureKind::interface ? inner : curve) ? on : std::vector<uint32_t>{};
}

// The collapse of b into a with its gain, if the rules allow it.
bool collapse_of(const InterfaceMesh& m, const ElementsAround<3>& around, const std::vector<std::vector<uint16_t>>& met,
                 const std::vector<float>& h, const CollapseOptions& o, uint32_t b, uint32_t a, Collapse& c) {
  const auto& V = m.vertices;
  if (glm::length(V[a] - V[b]) > o.max_length * std::min(h[a], h[b])) return false;
  c = {b, a, 0, edge_triangles(m, around, met, b, a), {}};
  if (c.gone.empty()) return false;
  const double min_cos = std::cos(o.max_turn_deg * M_PI / 180);
  auto within = [&](const glm::dvec3& u, const glm::dvec3& w) {
    return glm::dot(u, w) > min_cos * glm::length(u) * glm::length(w);
  };
  // An interface vertex's star, area-weighted (one interface, oriented alike): where its triangles fold, the surface's
  // normal, which a new triangle may follow instead of its own old one.
  const bool on_interface = FeatureKind(m.vertex_kind[b]) == FeatureKind::interface;
  glm::dvec3 mean(0.0);
  for (uint32_t t : around[b]) mean += triangle_normal(V, m.triangles[t]);
  double before = 1, after = 1;
  std::vector<std::pair<Triangle, Pair>> star_before, star_after;
  for (uint32_t t : around[b]) {
    before = std::min(before, radius_ratio(V[m.triangles[t][0]], V[m.triangles[t][1]], V[m.triangles[t][2]]));
    if (std::find(c.gone.begin(), c.gone.end(), t) != c.gone.end()) continue;
    const Triangle n = with_vertex(m.triangles[t], b, a);
    const glm::dvec3 u = triangle_normal(V, m.triangles[t]), w = triangle_normal(V, n);
    if (!within(u, w) && !(on_interface && within(mean, w))) return false;
    after = std::min(after, radius_ratio(V[n[0]], V[n[1]], V[n[2]]));
    c.changed.push_back(t);
    star_after.push_back({n, m.pair[t]});
  }
  c.gain = after - before;
  if (c.gain < o.min_gain) return false;
  std::vector<std::pair<Triangle, Pair>> star_b;
  for (uint32_t t : around[b]) star_b.push_back({m.triangles[t], m.pair[t]});
  for (uint32_t t : around[a]) {
    star_before.push_back({m.triangles[t], m.pair[t]});
    if (std::find(c.gone.begin(), c.gone.end(), t) == c.gone.end()) star_after.push_back(star_before.back());
  }
  if (!edges_valid(edges_at(a, star_after)) || !one_fan_each(a, star_before) || !one_fan_each(b, star_b) ||
      !one_fan_each(a, star_after))
    return false;
  return std::all_of(c.gone.begin(), c.gone.end(),
                     [&](uint32_t t) { return link_condition(m, around, m.pair[t], a, b); });
}

std::vector<Collapse> candidates(const InterfaceMesh& m, const ElementsAround<3>& around, const std::vector<float>& h,
                                const CollapseOptions& o) {
  const auto met = met_materials(m);
  std::vector<std::array<uint32_t, 2>> edges;
  for (const Triangle& t : m.triangles)
    for (int i = 0; i < 3; ++i) {
      const uint32_t u = t[size_t(i)], v = t[size_t((i + 1) % 3)];
      edges.push_back({std::min(u, v), std::max(u, v)});
    }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  std::vector<Collapse> out;
  for (const auto& [u, v] : edges) {
    Collapse x, y;
    const bool ux = collapse_of(m, around, met, h, o, u, v, x), vy = collapse_of(m, around, met, h, o, v, u, y);
    if (ux || vy) out.push_back(!vy || (ux && x.gain >= y.gain) ? std::move(x) : std::move(y));
  }
  std::sort(out.begin(), out.end(), [](const Collapse& p, const Collapse& q) {
    return p.gain != q.gain ? p.gain > q.gain : p.from < q.from;
  });
  return out;
}

// The collapses of one pass that no earlier one of the pass touched, applied; returns them with the triangles before.
struct Made {
  Collapse collapse;
  std::vector<Triangle> before;  // of gone, then changed
};
std::vector<Made> apply_pass(InterfaceMesh& m, const std::vector<float>& h, const CollapseOptions& o,
                             std::vector<uint8_t>& dead) {
  auto& T = m.triangles;
  const ElementsAround<3> around(m.vertices.size(), T);
  std::vector<uint8_t> touched(T.size(), 0);
  std::vector<Made> made;
  for (Collapse& c : candidates(m, around, h, o)) {
    bool free = true;
    for (uint32_t v : {c.from, c.to})
      for (uint32_t t : around[v]) free = free && !touched[t];
    if (!free) continue;
    for (uint32_t v : {c.from, c.to})
      for (uint32_t t : around[v]) touched[t] = 1;
    Made k{std::move(c), {}};
    for (uint32_t t : k.collapse.gone) k.before.push_back(T[t]), dead[t] = 1;
    for (uint32_t t : k.collapse.changed) k.before.push_back(T[t]), T[t] = with_vertex(T[t], k.collapse.from, k.collapse.to);
    made.push_back(std::move(k));
  }
  return made;
}

void undo(InterfaceMesh& m, const Made& k, std::vector<uint8_t>& dead) {
  size_t i = 0;
  for (uint32_t t : k.collapse.gone) m.triangles[t] = k.before[i++], dead[t] = 0;
  for (uint32_t t : k.collapse.changed) m.triangles[t] = k.before[i++];
}

// Undoes the collapses with a changed triangle that crosses another, until none is left; returns which are kept.
std::vector<uint8_t> undo_crossings(InterfaceMesh& m, const std::vector<Made>& made, std::vector<uint8_t>& dead) {
  std::vector<size_t> owner(m.triangles.size(), SIZE_MAX);
  for (size_t k = 0; k < made.size(); ++k)
    for (uint32_t t : made[k].collapse.changed) owner[t] = k;
  std::vector<uint8_t> kept(made.size(), 1);
  for (bool again = !made.empty(); again;) {
    again = false;
    std::vector<Triangle> live;
    std::vector<uint32_t> index;
    std::vector<uint8_t> only;
    for (uint32_t t = 0; t < m.triangles.size(); ++t)
      if (!dead[t]) live.push_back(m.triangles[t]), index.push_back(t), only.push_back(owner[t] != SIZE_MAX);
    for (const auto& pair : crossing_triangles(m.vertices, live, &only))
      for (uint32_t i : pair) {
        const size_t k = owner[index[i]];
        if (k == SIZE_MAX || !kept[k]) continue;
        undo(m, made[k], dead);
        kept[k] = 0;
        again = true;
      }
  }
  return kept;
}

// Drops the dead triangles; the changed ones of the kept collapses are no Delaunay faces any more.
void compact(InterfaceMesh& m, const std::vector<Made>& made, const std::vector<uint8_t>& kept,
             const std::vector<uint8_t>& dead) {
  if (!m.face.empty())
    for (size_t k = 0; k < made.size(); ++k)
      if (kept[k])
        for (uint32_t t : made[k].collapse.changed) m.face[t] = kNoFace;
  size_t live = 0;
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    if (dead[t]) continue;
    m.triangles[live] = m.triangles[t];
    m.pair[live] = m.pair[t];
    if (!m.face.empty()) m.face[live] = m.face[t];
    ++live;
  }
  m.triangles.resize(live), m.pair.resize(live);
  if (!m.face.empty()) m.face.resize(live);
}

}  // namespace

CollapseReport collapse_interface_edges(InterfaceMesh& mesh, const std::vector<float>& vertex_h,
                                        const CollapseOptions& options) {
  CollapseReport report;
  for (int pass = 0; pass < options.passes; ++pass) {
    std::vector<uint8_t> dead(mesh.triangles.size(), 0);
    const std::vector<Made> made = apply_pass(mesh, vertex_h, options, dead);
    const std::vector<uint8_t> kept = undo_crossings(mesh, made, dead);
    compact(mesh, made, kept, dead);
    const size_t undone = made.size() - size_t(std::count(kept.begin(), kept.end(), 1));
    report.collapses += made.size() - undone;
    report.undone += undone;
    if (made.size() == undone) break;
  }
  return report;
}

}  // namespace cpmesh::mesh
