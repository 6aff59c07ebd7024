#include "mesh/interface_flips.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "mesh/quality.h"

namespace cpmesh::mesh {
namespace {

using Triangle = std::array<uint32_t, 3>;
using Edge = std::array<uint32_t, 2>;

Edge edge_of(uint32_t a, uint32_t b) { return {std::min(a, b), std::max(a, b)}; }

double ratio_of(const std::vector<glm::dvec3>& V, const Triangle& t) { return radius_ratio(V[t[0]], V[t[1]], V[t[2]]); }

// Whether the normals of x and y are within the angle whose cosine is `min_cos` (false for a degenerate one).
bool flat(const std::vector<glm::dvec3>& V, const Triangle& x, const Triangle& y, double min_cos) {
  const glm::dvec3 a = triangle_normal(V, x), b = triangle_normal(V, y);
  const double la = glm::length(a), lb = glm::length(b);
  return la > 0 && lb > 0 && glm::dot(a, b) >= min_cos * la * lb;
}

// The corner of t after `from`, and the one after that.
std::array<uint32_t, 2> after(const Triangle& t, uint32_t from) {
  const int i = t[0] == from ? 0 : t[1] == from ? 1 : 2;
  return {t[size_t((i + 1) % 3)], t[size_t((i + 2) % 3)]};
}

struct Flip {
  uint32_t t1, t2;
  Triangle n1, n2;
  double gain;
};

// The flip of the edge shared by t1 and t2, if it is one (interface_flips.h): t1 = (a, b, c) and t2 = (b, a, d) become
// (c, a, d) and (d, b, c), the same orientation.
bool flip_of(const InterfaceMesh& m, uint32_t t1, uint32_t t2, const Edge& e, const FlipOptions& o, Flip& flip) {
  const auto& V = m.vertices;
  const Triangle& x = m.triangles[t1];
  const Triangle& y = m.triangles[t2];
  uint32_t a = e[0], b = e[1];
  if (after(x, a)[0] != b) std::swap(a, b);
  const uint32_t c = after(x, a)[1];
  if (after(y, b)[0] != a) return false;  // not oriented alike
  const uint32_t d = after(y, b)[1];
  if (c == d) return false;
  flip = {t1, t2, {c, a, d}, {d, b, c}, 0};
  const double min_cos = std::cos(o.max_fold_deg * M_PI / 180);
  if (!flat(V, x, y, min_cos) || !flat(V, flip.n1, flip.n2, min_cos) || !flat(V, x, flip.n1, min_cos)) return false;
  flip.gain = std::min(ratio_of(V, flip.n1), ratio_of(V, flip.n2)) - std::min(ratio_of(V, x), ratio_of(V, y));
  return flip.gain >= o.min_gain;
}

// Every edge with the triangles on it, sorted by edge.
std::vector<std::pair<Edge, uint32_t>> edge_table(const std::vector<Triangle>& T) {
  std::vector<std::pair<Edge, uint32_t>> edges;
  edges.reserve(3 * T.size());
  for (uint32_t t = 0; t < T.size(); ++t)
    for (int i = 0; i < 3; ++i) edges.push_back({edge_of(T[t][size_t(i)], T[t][size_t((i + 1) % 3)]), t});
  std::sort(edges.begin(), edges.end());
  return edges;
}

std::vector<Flip> candidates(const InterfaceMesh& m, const std::vector<std::pair<Edge, uint32_t>>& edges,
                             const FlipOptions& o) {
  std::vector<Flip> out;
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j].first == edges[i].first) ++j;
    Flip f;
    if (j - i == 2 && m.pair[edges[i].second] == m.pair[edges[i + 1].second] &&
        flip_of(m, edges[i].second, edges[i + 1].second, edges[i].first, o, f))
      out.push_back(f);
    i = j;
  }
  std::sort(out.begin(), out.end(), [](const Flip& p, const Flip& q) {
    return p.gain != q.gain ? p.gain > q.gain : p.t1 < q.t1;
  });
  return out;
}

// One pass: the flips whose triangles no earlier flip of the pass touched, then undoing those with a crossing.
FlipReport flip_pass(InterfaceMesh& m, const FlipOptions& o) {
  auto& T = m.triangles;
  const auto edges = edge_table(T);
  std::vector<uint32_t> degree(m.vertices.size(), 0);
  for (const auto& t : T)
    for (uint32_t v : t) ++degree[v];
  auto exists = [&](const Edge& e) {
    const auto it = std::lower_bound(edges.begin(), edges.end(), std::make_pair(e, uint32_t(0)));
    return it != edges.end() && it->first == e;
  };
  std::vector<uint8_t> flipped(T.size(), 0);
  std::set<Edge> added;
  std::vector<std::pair<Flip, std::array<Triangle, 2>>> made;  // with the triangles before
  for (const Flip& f : candidates(m, edges, o)) {
    const Edge fresh = edge_of(f.n1[0], f.n1[2]);  // c-d
    const uint32_t a = f.n1[1], b = f.n2[1];
    if (flipped[f.t1] || flipped[f.t2] || exists(fresh) || added.count(fresh) || degree[a] < 4 || degree[b] < 4)
      continue;
    made.push_back({f, {T[f.t1], T[f.t2]}});
    T[f.t1] = f.n1, T[f.t2] = f.n2;
    flipped[f.t1] = flipped[f.t2] = 1;
    added.insert(fresh);
    --degree[a], --degree[b], ++degree[f.n1[0]], ++degree[f.n1[2]];
  }
  FlipReport report;
  std::vector<size_t> flip_of_triangle(T.size(), SIZE_MAX);
  for (size_t k = 0; k < made.size(); ++k) flip_of_triangle[made[k].first.t1] = flip_of_triangle[made[k].first.t2] = k;
  std::vector<uint8_t> kept(made.size(), 1);
  for (bool again = !made.empty(); again;) {
    again = false;
    for (const auto& pair : crossing_triangles(m.vertices, T, &flipped))
      for (uint32_t t : pair) {
        const size_t k = flip_of_triangle[t];
        if (k == SIZE_MAX || !kept[k]) continue;
        T[made[k].first.t1] = made[k].second[0], T[made[k].first.t2] = made[k].second[1];
        kept[k] = 0;
        ++report.undone;
        again = true;
      }
  }
  for (size_t k = 0; k < made.size(); ++k)
    if (kept[k]) {
      ++report.flips;
      if (!m.face.empty()) m.face[made[k].first.t1] = m.face[made[k].first.t2] = kNoFace;
    }
  return report;
}

}  // namespace

FlipReport flip_interface_edges(InterfaceMesh& mesh, const FlipOptions& options) {
  FlipReport report;
  for (int pass = 0; pass < options.passes; ++pass) {
    const FlipReport r = flip_pass(mesh, options);
    report.flips += r.flips;
    report.undone += r.undone;
    if (r.flips == 0) break;
  }
  return report;
}

}  // namespace cpmesh::mesh
