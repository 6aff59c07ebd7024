#include "mesh/refine.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <optional>
#include <span>
#include <unordered_map>

#include <tbb/parallel_for.h>

#include "fields/closest_point_embedding.h"
#include "mesh/face_key.h"
#include "ref/cp_lookup.h"

namespace cpmesh::mesh {

namespace {

// Points hashed into cubes of a fixed side: "is any point within r of q" for r up to that side.
class PointHash {
 public:
  explicit PointHash(double cell) : cell_(cell) {}
  void add(const glm::dvec3& p, int64_t index) { cells_[key(cell_of(p))].push_back({p, index}); }
  // The index of the nearest point within r of q other than `skip`, or -1 (-2 where the nearest has no index).
  int64_t nearest_within(const glm::dvec3& q, double r, int64_t skip = -1) const {
    const glm::ivec3 c = cell_of(q);
    int64_t best = -1;
    double best_d = r;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const auto it = cells_.find(key(c + glm::ivec3(dx, dy, dz)));
          if (it == cells_.end()) continue;
          for (const auto& [p, index] : it->second)
            if (const double d = glm::length(p - q); d < best_d && (index != skip || index < 0)) best_d = d, best = index;
        }
    return best;
  }

 private:
  glm::ivec3 cell_of(const glm::dvec3& p) const { return glm::ivec3(glm::floor(p / cell_)); }
  static uint64_t key(const glm::ivec3& c) {
    return (uint64_t(uint32_t(c.x)) * 0x9e3779b97f4a7c15ull) ^ (uint64_t(uint32_t(c.y)) * 0xc2b2ae3d27d4eb4full) ^
           (uint64_t(uint32_t(c.z)) * 0x165667b19e3779f9ull);
  }
  double cell_;
  std::unordered_map<uint64_t, std::vector<std::pair<glm::dvec3, int64_t>>> cells_;
};

// The embedding feature of exactly `materials` (ascending): two name an interface, three a triple curve, four or
// more the quadruple point of the first four; -1 where the embedding has none.
int feature_of(const fields::ClosestPointEmbedding& E, std::span<const uint16_t> materials) {
  using fields::FeatureKind;
  std::array<uint16_t, 4> key = {0xffff, 0xffff, 0xffff, 0xffff};
  std::copy_n(materials.begin(), std::min(materials.size(), key.size()), key.begin());
  const size_t n = materials.size();
  return E.feature_index(n == 2 ? FeatureKind::interface : n == 3 ? FeatureKind::triple_curve : FeatureKind::quadruple_point, key);
}

// The features a site may take a sample on: the interface of m and o, and the triple curves and quadruple points of
// m, o and the materials its vertices lie on.
std::vector<uint32_t> candidate_features(const fields::ClosestPointEmbedding& E, const RefineSite& s) {
  std::vector<uint16_t> others;
  for (uint16_t m : s.vertex_materials)
    if (m != s.m && m != s.o) others.push_back(m);
  std::vector<uint32_t> out;
  auto add = [&](std::vector<uint16_t> mats) {
    std::sort(mats.begin(), mats.end());
    if (const int f = feature_of(E, mats); f >= 0) out.push_back(uint32_t(f));
  };
  add({s.m, s.o});
  for (size_t a = 0; a < others.size(); ++a) {
    add({s.m, s.o, others[a]});
    for (size_t b = a + 1; b < others.size(); ++b) add({s.m, s.o, others[a], others[b]});
  }
  return out;
}

// The closest point to p of the feature of exactly `materials` (ascending: a triple curve or quadruple point), when
// it exists and lies within h of p.
std::optional<RefinePoint> junction_point(const fields::ClosestPointEmbedding& E, const glm::dvec3& p,
                                          const std::vector<uint16_t>& materials) {
  if (materials.size() < 3 || materials.size() > 4) return std::nullopt;
  const int f = feature_of(E, materials);
  if (f < 0) return std::nullopt;
  const auto cp = ref::cp_lookup(E, glm::vec3(p), uint32_t(f));
  const glm::dvec3 q(glm::vec3(cp.value));
  if (!cp.valid || !(glm::length(q - p) <= cp.value.w)) return std::nullopt;
  return RefinePoint{q, uint32_t(f), cp.value.w};
}

}  // namespace

namespace {

// Where the material first changes along a -> b (local coordinates), to a twentieth of a voxel; nullopt when the
// samples show no change.
std::optional<glm::dvec3> material_change(const fields::IndicatorFields& F, glm::dvec3 a, glm::dvec3 b) {
  const glm::dvec3 top = glm::dvec3(F.grid.dims - 1) * F.grid.spacing;
  a = glm::clamp(a, glm::dvec3(0.0), top);
  b = glm::clamp(b, glm::dvec3(0.0), top);
  auto at = [&](const glm::dvec3& p) { return F.material_at(p / F.grid.spacing); };
  const int start = at(a);
  const int samples = std::clamp(int(std::ceil(glm::length(b - a) / F.grid.min_spacing())) * 2, 2, 256);
  glm::dvec3 lo = a;
  for (int i = 1; i <= samples; ++i) {
    const glm::dvec3 hi = a + (b - a) * (double(i) / samples);
    if (at(hi) == start) {
      lo = hi;
      continue;
    }
    glm::dvec3 h = hi;
    for (int k = 0; k < 12 && glm::length(h - lo) > 0.05 * F.grid.min_spacing(); ++k) {
      const glm::dvec3 mid = (lo + h) / 2.0;
      (at(mid) == start ? lo : h) = mid;
    }
    return (lo + h) / 2.0;
  }
  return std::nullopt;
}

}  // namespace

std::vector<RefineSite> face_sites(const fields::IndicatorFields& F, const Tets& T, const Adjacency& adj,
                                   const std::vector<uint16_t>& hull, const std::vector<uint16_t>& material,
                                   const std::vector<fields::MaterialList>& vertex_materials, const std::vector<uint32_t>& faces) {
  std::vector<RefineSite> out(faces.size());
  tbb::parallel_for(size_t(0), faces.size(), [&](size_t i) {
    const uint32_t tc = faces[i];
    const auto f = outward_face(T, tc);
    const uint32_t nb = adj.neighbour[tc];
    const glm::dvec3 a = label_point(T, tc / 4), b = nb == Adjacency::kHull ? hull_sample_point(F, T, tc) : label_point(T, nb / 4);
    RefineSite s{(T.points[f[0]] + T.points[f[1]] + T.points[f[2]]) / 3.0, material[tc / 4],
                 material_across(adj, hull, material, tc), {}, f, 0.0, false};
    if (const auto c = material_change(F, a, b)) s.at = *c;
    s.radius = std::min({glm::length(T.points[f[0]] - s.at), glm::length(T.points[f[1]] - s.at),
                         glm::length(T.points[f[2]] - s.at)});
    s.wrong = face_is_wrong(T, tc, s.m, s.o, vertex_materials);
    s.vertex_materials = fields::union_of(std::array{vertex_materials[f[0]], vertex_materials[f[1]], vertex_materials[f[2]]});
    out[i] = s;
  });
  return out;
}

std::vector<uint32_t> nonmanifold_faces(const InterfaceMesh& I) {
  struct Edge {
    uint32_t a, b, group, triangle;
    auto operator<=>(const Edge&) const = default;
  };
  std::vector<Edge> edges;
  edges.reserve(3 * I.triangles.size());
  for (uint32_t t = 0; t < I.triangles.size(); ++t) {
    const auto& tri = I.triangles[t];
    const uint32_t g = pair_key(I.pair[t][0], I.pair[t][1]);
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = tri[size_t(k)], b = tri[size_t((k + 1) % 3)];
      edges.push_back({std::min(a, b), std::max(a, b), g, t});
    }
  }
  std::sort(edges.begin(), edges.end());
  const auto interface_kind = uint8_t(fields::FeatureKind::interface);
  std::vector<uint32_t> out;
  for (size_t i = 0; i < edges.size();) {
    // The run of one vertex pair (all interfaces), and within it the runs of one interface.
    size_t end = i;
    while (end < edges.size() && edges[end].a == edges[i].a && edges[end].b == edges[i].b) ++end;
    for (size_t j = i; j < end;) {
      size_t k = j;
      while (k < end && edges[k].group == edges[j].group) ++k;
      const Edge& e = edges[j];
      const bool on_junctions = I.vertex_kind[e.a] != interface_kind && I.vertex_kind[e.b] != interface_kind;
      if (edge_excess(k - j, end - i, on_junctions) > 0)
        for (size_t q = j; q < k; ++q) out.push_back(I.face[edges[q].triangle]);
      j = k;
    }
    i = end;
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

namespace {

// How many fans the triangles `run` (indices into T, all through vertex v) form: two are of one fan where they share
// an edge through v.
size_t fans_at(uint32_t v, std::span<const uint32_t> run, const std::vector<std::array<uint32_t, 3>>& T) {
  std::vector<int> fan(run.size(), -1);
  size_t fans = 0;
  std::vector<size_t> stack;
  for (size_t s = 0; s < run.size(); ++s) {
    if (fan[s] >= 0) continue;
    fan[s] = int(fans);
    stack.assign(1, s);
    while (!stack.empty()) {
      const auto& a = T[run[stack.back()]];
      stack.pop_back();
      for (size_t o = 0; o < run.size(); ++o) {
        if (fan[o] >= 0) continue;
        const auto& b = T[run[o]];
        for (uint32_t u : a)
          if (u != v && std::find(b.begin(), b.end(), u) != b.end()) {
            fan[o] = int(fans);
            stack.push_back(o);
            break;
          }
      }
    }
    ++fans;
  }
  return fans;
}

}  // namespace

std::vector<uint32_t> pinched_vertex_faces(const InterfaceMesh& I) {
  struct Corner {
    uint32_t v, group, triangle;
    auto operator<=>(const Corner&) const = default;
  };
  std::vector<Corner> corners;  // the junction vertices' only: an interface vertex's pinch is left
  for (uint32_t t = 0; t < I.triangles.size(); ++t)
    for (uint32_t v : I.triangles[t])
      if (I.vertex_kind[v] != uint8_t(fields::FeatureKind::interface))
        corners.push_back({v, pair_key(I.pair[t][0], I.pair[t][1]), t});
  std::sort(corners.begin(), corners.end());
  std::vector<uint32_t> out, run;
  for (size_t i = 0; i < corners.size();) {
    size_t j = i;
    run.clear();
    for (; j < corners.size() && corners[j].v == corners[i].v && corners[j].group == corners[i].group; ++j)
      run.push_back(corners[j].triangle);
    if (run.size() > 1 && fans_at(corners[i].v, run, I.triangles) > 1)
      for (uint32_t t : run) out.push_back(I.face[t]);
    i = j;
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

namespace {

// The closest point of feature f to p: the embedding's lookup, or where its stencil is incomplete, Newton on the
// fields from p, kept when it converges onto the feature (no other material above it) within `reach` of p.
std::optional<RefinePoint> closest_on_feature(const fields::IndicatorFields& F, const fields::ClosestPointEmbedding& E,
                                              const glm::dvec3& p, uint32_t f, double reach, float h) {
  const auto cp = ref::cp_lookup(E, glm::vec3(p), f);
  if (cp.valid) return RefinePoint{glm::dvec3(glm::vec3(cp.value)), f, cp.value.w};
  glm::dvec3 q;
  if (!fields::project_to_feature(F, E.features[f], p, q, 30, 3, nullptr, true)) return std::nullopt;
  if (!(glm::length(q - p) <= reach) || !(fields::feature_distance(F, E.features[f], q) < 0.05 * F.grid.min_spacing()))
    return std::nullopt;
  return RefinePoint{q, f, h};
}

// Per site, the sample: as the junction protection leaves interface particles out near curves and points, a point
// or curve whose closest point lies within `protection` x h of the site takes it (the lowest dimension first), else
// the nearest feature does; h -1 where no feature has a closest point here.
RefinePoint site_sample(const fields::IndicatorFields& F, const fields::ClosestPointEmbedding& E, const RefineSite& s,
                        const RefineVertices& V, double protection) {
  const float face_h = std::min({V.h[s.vertices[0]], V.h[s.vertices[1]], V.h[s.vertices[2]]});
  RefinePoint best{}, nearest{{}, 0, -1};
  double nearest_distance = INFINITY;
  int best_rank = 3;
  for (uint32_t f : candidate_features(E, s)) {
    const auto c = closest_on_feature(F, E, s.at, f, std::max(2.0 * s.radius, double(face_h)), face_h);
    if (!c) continue;
    const double d = glm::length(c->position - s.at);
    const int rank = int(E.features[f].kind);  // 0 point, 1 curve, 2 interface
    if (d < nearest_distance) nearest_distance = d, nearest = *c;
    if (rank < 2 && d < protection * c->h && rank < best_rank) best_rank = rank, best = *c;
  }
  return best_rank < 3 ? best : nearest;
}

}  // namespace

Refinement refinement_points(const fields::IndicatorFields& F, const fields::ClosestPointEmbedding& E,
                             const std::vector<RefineSite>& sites, const RefineVertices& V, double protection) {
  std::vector<RefinePoint> chosen(sites.size());
  tbb::parallel_for(size_t(0), sites.size(), [&](size_t i) { chosen[i] = site_sample(F, E, sites[i], V, protection); });
  // Crowding, against the points and then among the new ones in site order. A point in the way that lies on no
  // feature of the site's two materials is on the wrong feature there: it moves to the sample instead.
  float largest_h = 0;
  for (const auto& c : chosen) largest_h = std::max(largest_h, c.h);
  Refinement out;
  if (chosen.empty() || !(largest_h > 0)) return out;
  PointHash near(kCrowding * largest_h);
  for (size_t v = 0; v < V.points.size(); ++v) near.add(V.points[v], int64_t(v));
  std::vector<uint8_t> taken(V.points.size(), 0);  // moved or removed in this round
  auto fixed = [&](size_t v) { return v < V.fixed.size() && V.fixed[v]; };
  auto move = [&](uint32_t v, const RefinePoint& to) {
    taken[v] = 1;
    out.moved.push_back({v, to});
    near.add(to.position, -2);
  };
  const double floor = kMinCrowding * F.grid.min_spacing();
  // Only interface samples squeeze in closer (refine.h): a junction sample beside a junction vertex is the same
  // junction, a sliver in the making (clustered_junction_points).
  auto crowding = [&](const RefinePoint& c, const RefineSite& s) {
    const bool squeeze = !s.wrong && E.features[c.feature].kind == fields::FeatureKind::interface;
    return std::max(floor, squeeze ? std::min(kCrowding * c.h, kBallShare * s.radius) : kCrowding * c.h);
  };
  for (size_t i = 0; i < chosen.size(); ++i) {
    const RefinePoint& c = chosen[i];
    if (!(c.h > 0)) continue;
    const int64_t v = near.nearest_within(c.position, crowding(c, sites[i]));
    const uint16_t m = sites[i].m, o = sites[i].o;
    auto lacks_pair = [&](size_t w) { return !V.materials[w].has(m) || !V.materials[w].has(o); };
    if (v == -1) {
      out.added.push_back(c);
      near.add(c.position, -2);
    } else if (v >= 0 && !taken[size_t(v)] && !fixed(size_t(v)) && lacks_pair(size_t(v)) &&
               near.nearest_within(c.position, crowding(c, sites[i]), v) == -1) {
      move(uint32_t(v), c);
    } else if (v >= 0 && !taken[size_t(v)] && lacks_pair(size_t(v))) {
      taken[size_t(v)] = 1, out.removed.push_back(uint32_t(v));
    } else if (v >= 0) {
      // A point on a right feature is in the way: the face's vertices that lack one of the two materials move to
      // the junction of their own materials and the two, where it lies within h and has room, or are removed.
      for (uint32_t w : sites[i].vertices) {
        if (taken[w] || !lacks_pair(w)) continue;
        const auto to = junction_point(E, V.points[w], fields::union_of(std::span(&V.materials[w], 1), {m, o}));
        const int64_t in_way = to ? near.nearest_within(to->position, crowding(*to, sites[i])) : -1;
        if (to && !fixed(w) && (in_way == -1 || in_way == int64_t(w)))
          move(w, *to);
        else
          taken[w] = 1, out.removed.push_back(w);
      }
    }
  }
  return out;
}

std::vector<uint32_t> clustered_junction_points(const std::vector<glm::dvec3>& points, const std::vector<uint8_t>& kind,
                                                const std::vector<float>& h, double voxel) {
  auto radius = [&](uint32_t v) { return junction_radius(h[v], voxel); };
  std::vector<uint32_t> junctions;
  double largest = kMinCrowding * voxel;
  for (uint32_t v = 0; v < points.size(); ++v)
    if (kind[v] == uint8_t(fields::FeatureKind::quadruple_point)) {
      junctions.push_back(v);
      largest = std::max(largest, radius(v));
    }
  PointHash kept(largest);
  std::vector<uint32_t> out;
  for (uint32_t v : junctions) {
    if (kept.nearest_within(points[v], radius(v)) != -1) out.push_back(v);
    else kept.add(points[v], v);
  }
  for (uint32_t v = 0; v < points.size(); ++v)
    if (kind[v] == uint8_t(fields::FeatureKind::triple_curve) && kept.nearest_within(points[v], radius(v)) != -1)
      out.push_back(v);
  std::sort(out.begin(), out.end());
  return out;
}

size_t widen_to_near_junctions(const fields::IndicatorFields& F, const fields::ClosestPointEmbedding& E, const Tets& T, const Adjacency& adj,
                               const std::vector<uint16_t>& hull, const std::vector<uint16_t>& material,
                               const std::vector<uint32_t>& wrong, const std::vector<float>& h,
                               std::vector<fields::MaterialList>& vertex_materials) {
  size_t widened = 0;
  for (uint32_t tc : wrong) {
    const uint16_t m = material[tc / 4], o = material_across(adj, hull, material, tc);
    for (uint32_t v : outward_face(T, tc)) {
      fields::MaterialList& own = vertex_materials[v];
      if ((own.has(m) && own.has(o)) || own.size() < 3) continue;
      const std::vector<uint16_t> needed = fields::union_of(std::span(&own, 1), {m, o});
      if (needed.size() > kMaxJunctionMaterials) continue;
      const glm::dvec3& p = T.points[v];
      // Every junction among the needed materials that holds the ones the vertex lacks, the quadruple point first.
      for (uint32_t subset = (1u << needed.size()) - 1; subset > 0; --subset) {
        std::vector<uint16_t> S;
        for (size_t i = 0; i < needed.size(); ++i)
          if (subset >> i & 1) S.push_back(needed[i]);
        const bool holds_missing = (own.has(m) || std::count(S.begin(), S.end(), m)) &&
                                   (own.has(o) || std::count(S.begin(), S.end(), o));
        if (S.size() < 3 || !holds_missing) continue;
        // A subset of five or more materials names the quadruple point of its first four: where five or more labels
        // crowd within a voxel, that point stands for the cluster (docs/design.md, "Junctions closer than the
        // crowding radius").
        const int f = feature_of(E, S);
        const double radius = junction_radius(h[v], F.grid.min_spacing());
        if (f < 0) continue;
        const auto on = closest_on_feature(F, E, p, uint32_t(f), radius, h[v]);
        if (!on || !(glm::length(on->position - p) <= radius)) continue;
        std::vector<uint16_t> grown = own.members();
        grown.insert(grown.end(), S.begin(), S.end());
        own = fields::MaterialList(std::move(grown));
        ++widened;
        break;
      }
    }
  }
  return widened;
}

std::vector<std::pair<uint32_t, RefinePoint>> wrong_vertex_junctions(const fields::IndicatorFields& F,
                                                             const fields::ClosestPointEmbedding& E, const Tets& T,
                                                             const Adjacency& adj, const std::vector<uint16_t>& hull,
                                                             const std::vector<uint16_t>& material,
                                                             const std::vector<uint32_t>& wrong, const std::vector<float>& h,
                                                             const std::vector<fields::MaterialList>& vertex_materials) {
  const double reach = kJunctionReach * F.grid.min_spacing();
  std::vector<std::pair<uint32_t, RefinePoint>> out;
  for (uint32_t tc : wrong) {
    const uint16_t m = material[tc / 4], o = material_across(adj, hull, material, tc);
    for (uint32_t v : outward_face(T, tc)) {
      const fields::MaterialList& own = vertex_materials[v];
      const bool taken = std::any_of(out.begin(), out.end(), [&](const auto& s) { return s.first == v; });
      if (own.size() != 2 || (own.has(m) && own.has(o)) || taken) continue;
      const int f = feature_of(E, fields::union_of(std::span(&own, 1), {m, o}));  // three or four materials
      const auto to = f < 0 ? std::nullopt : closest_on_feature(F, E, T.points[v], uint32_t(f), reach, h[v]);
      if (to && glm::length(to->position - T.points[v]) <= reach) out.push_back({v, *to});
    }
  }
  return out;
}

}  // namespace cpmesh::mesh
