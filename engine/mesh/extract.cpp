#include "mesh/extract.h"

#include "mesh/face_key.h"
#include "mesh/quality.h"

#include <algorithm>
#include <numeric>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace cpmesh::mesh {

namespace {

constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};  // face opposite corner c

}  // namespace

glm::dvec3 circumcentre(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d, bool& ok) {
  const glm::dvec3 u = b - a, v = c - a, w = d - a;
  const double det = glm::dot(u, glm::cross(v, w));
  const double scale = glm::length(u) * glm::length(v) * glm::length(w);
  ok = std::fabs(det) > 1e-9 * scale;
  if (!ok) return (a + b + c + d) / 4.0;
  return a + (glm::dot(u, u) * glm::cross(v, w) + glm::dot(v, v) * glm::cross(w, u) + glm::dot(w, w) * glm::cross(u, v)) / (2 * det);
}

Adjacency build_adjacency(const Tets& T) {
  if (T.neighbours.size() == T.tets.size() * 4) {
    // TetGen's neighbours: for each pair, the corner of each tet that the other lacks names the shared face. Found
    // by vertices, so TetGen's slot order does not matter.
    Adjacency adj;
    adj.neighbour.assign(T.tets.size() * 4, Adjacency::kHull);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, T.tets.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t t = r.begin(); t < r.end(); ++t)
        for (int s = 0; s < 4; ++s) {
          const int32_t n = T.neighbours[t * 4 + size_t(s)];
          if (n < 0) continue;
          const auto &a = T.tets[t], &b = T.tets[size_t(n)];
          auto lacking = [](const std::array<uint32_t, 4>& x, const std::array<uint32_t, 4>& y) {
            for (int c = 0; c < 4; ++c)
              if (std::find(y.begin(), y.end(), x[size_t(c)]) == y.end()) return c;
            return -1;
          };
          const int ca = lacking(a, b), cb = lacking(b, a);
          if (ca >= 0 && cb >= 0) adj.neighbour[t * 4 + size_t(ca)] = uint32_t(size_t(n) * 4 + size_t(cb));
        }
    });
    return adj;
  }
  std::vector<std::pair<FaceKey, uint32_t>> faces;  // (face, tet * 4 + corner)
  faces.reserve(T.tets.size() * 4);
  for (size_t t = 0; t < T.tets.size(); ++t)
    for (int c = 0; c < 4; ++c)
      faces.push_back({FaceKey({T.tets[t][size_t(kFace[c][0])], T.tets[t][size_t(kFace[c][1])], T.tets[t][size_t(kFace[c][2])]}),
                       uint32_t(t * 4 + size_t(c))});
  std::sort(faces.begin(), faces.end());
  Adjacency adj;
  adj.neighbour.assign(T.tets.size() * 4, Adjacency::kHull);
  for (size_t i = 0; i + 1 < faces.size(); ++i)
    if (faces[i].first == faces[i + 1].first) {
      adj.neighbour[faces[i].second] = faces[i + 1].second;
      adj.neighbour[faces[i + 1].second] = faces[i].second;
    }
  return adj;
}

bool insert_points(Tets& T, Adjacency& adj, const std::vector<glm::dvec3>& points, const std::vector<uint32_t>& near_tet) {
  if (points.empty()) return true;
  if (T.tets.empty()) return false;
  const auto old_box = bounding_box(T.points), new_box = bounding_box(points);
  init_exact_predicates(glm::max(old_box[1], new_box[1]) - glm::min(old_box[0], new_box[0]));
  T.neighbours.clear();
  auto corner_point = [&](uint32_t t, int c) { return T.points[T.tets[t][size_t(c)]]; };
  auto face_point = [&](uint32_t t, int c, int k) { return T.points[T.tets[t][size_t(kFace[c][k])]]; };
  auto orientation = [&](const std::array<uint32_t, 4>& v) {
    return orient3d_exact(T.points[v[0]], T.points[v[1]], T.points[v[2]], T.points[v[3]]);
  };
  for (size_t i = 0; i < points.size(); ++i) {
    const glm::dvec3 q = points[i];
    // Locate: step across any face that separates q from the tet's opposite corner (a visibility walk; it ends on
    // a Delaunay tetrahedralization).
    uint32_t t = near_tet[i] < T.tets.size() ? near_tet[i] : 0;
    bool found = false;
    for (size_t steps = 0; steps < 4 * T.tets.size() + 16 && !found; ++steps) {
      found = true;
      for (int k = 0; k < 4; ++k) {
        const int c = int((steps + size_t(k)) % 4);  // rotating start: no cycling on ties
        const glm::dvec3 a = face_point(t, c, 0), b = face_point(t, c, 1), d = face_point(t, c, 2);
        const double side_q = orient3d_exact(a, b, d, q), side_v = orient3d_exact(a, b, d, corner_point(t, c));
        if (side_q * side_v >= 0) continue;
        const uint32_t n = adj.neighbour[size_t(t) * 4 + size_t(c)];
        if (n == Adjacency::kHull) return false;  // outside the hull
        t = n / 4;
        found = false;
        break;
      }
    }
    if (!found) return false;
    // The cavity: tets whose circumsphere holds q strictly, grown from t; its boundary faces (tet, corner). A cavity
    // is a few dozen tets: membership is a search of the list.
    std::vector<uint32_t> cavity = {t};
    auto in_cavity = [&](uint32_t u) { return std::find(cavity.begin(), cavity.end(), u) != cavity.end(); };
    auto inside = [&](uint32_t u) {
      const auto& v = T.tets[u];
      const double o = orientation(v);
      return o != 0 && insphere_exact(T.points[v[0]], T.points[v[1]], T.points[v[2]], T.points[v[3]], q) * o > 0;
    };
    std::vector<std::pair<uint32_t, int>> boundary;
    for (size_t k = 0; k < cavity.size(); ++k) {
      const uint32_t u = cavity[k];
      for (int c = 0; c < 4; ++c) {
        const uint32_t n = adj.neighbour[size_t(u) * 4 + size_t(c)];
        if (n != Adjacency::kHull && in_cavity(n / 4)) continue;
        if (n != Adjacency::kHull && inside(n / 4)) {
          cavity.push_back(n / 4);
        } else {
          boundary.push_back({u, c});
        }
      }
    }
    // Each new tet is its cavity tet with the boundary face's opposite corner moved to q: the same orientation, or q
    // is on that face's plane (a flat tet) or on a vertex.
    std::vector<std::array<uint32_t, 4>> made;
    const uint32_t qi = uint32_t(T.points.size());
    T.points.push_back(q);
    bool flat = false;
    for (const auto& [u, c] : boundary) {
      std::array<uint32_t, 4> v = T.tets[u];
      const double before = orientation(v);
      v[size_t(c)] = qi;
      const double after = orientation(v);
      flat = flat || !(before * after > 0);
      made.push_back(v);
    }
    // The faces through q pair up by their edge on the cavity's boundary (a closed surface: every edge twice).
    std::vector<std::pair<uint64_t, uint32_t>> edges;  // (edge key, made index * 4 + corner)
    for (size_t k = 0; k < made.size(); ++k) {
      const int c = boundary[k].second;
      for (int j = 0; j < 4; ++j) {
        if (j == c) continue;
        uint32_t e[2], m = 0;
        for (int x = 0; x < 4; ++x)
          if (x != j && x != c) e[m++] = made[k][size_t(x)];
        edges.push_back({uint64_t(std::min(e[0], e[1])) << 32 | std::max(e[0], e[1]), uint32_t(k * 4) + uint32_t(j)});
      }
    }
    std::sort(edges.begin(), edges.end());
    bool closed = edges.size() % 2 == 0;
    for (size_t k = 0; closed && k + 1 < edges.size(); k += 2)
      closed = edges[k].first == edges[k + 1].first && (k + 2 >= edges.size() || edges[k + 2].first != edges[k].first);
    if (flat || !closed) {
      T.points.pop_back();
      return false;
    }
    // Slots: the cavity's, then new ones. Outer faces keep their outside neighbour.
    std::vector<uint32_t> slot(made.size()), outside(made.size());
    for (size_t k = 0; k < made.size(); ++k) {
      outside[k] = adj.neighbour[size_t(boundary[k].first) * 4 + size_t(boundary[k].second)];
      slot[k] = k < cavity.size() ? cavity[k] : uint32_t(T.tets.size());
      if (k >= cavity.size()) {
        T.tets.push_back({});
        adj.neighbour.resize(adj.neighbour.size() + 4, Adjacency::kHull);
      }
    }
    for (size_t k = 0; k < made.size(); ++k) {
      const uint32_t s = slot[k], c = uint32_t(boundary[k].second);
      T.tets[s] = made[k];
      adj.neighbour[size_t(s) * 4 + c] = outside[k];
      if (outside[k] != Adjacency::kHull) adj.neighbour[outside[k]] = s * 4 + c;
    }
    for (size_t k = 0; k < edges.size(); k += 2) {
      const uint32_t a = slot[edges[k].second / 4] * 4 + edges[k].second % 4;
      const uint32_t b = slot[edges[k + 1].second / 4] * 4 + edges[k + 1].second % 4;
      adj.neighbour[a] = b;
      adj.neighbour[b] = a;
    }
    // A cavity can hold more tets than its boundary has faces (a convex polytope's triangulations differ in size):
    // its slots left over are filled with the last tets, highest slot first.
    std::vector<uint32_t> unused(cavity.begin() + ptrdiff_t(std::min(made.size(), cavity.size())), cavity.end());
    std::sort(unused.rbegin(), unused.rend());
    for (uint32_t dead : unused) {
      const uint32_t last = uint32_t(T.tets.size() - 1);
      if (dead != last) {
        T.tets[dead] = T.tets[last];
        for (uint32_t c = 0; c < 4; ++c) {
          const uint32_t n = adj.neighbour[size_t(last) * 4 + c];
          adj.neighbour[size_t(dead) * 4 + c] = n;
          if (n != Adjacency::kHull) adj.neighbour[n] = dead * 4 + c;
        }
      }
      T.tets.pop_back();
      adj.neighbour.resize(adj.neighbour.size() - 4);
    }
  }
  return true;
}

std::array<uint32_t, 3> outward_face(const Tets& T, uint32_t tc) {
  const auto& v = T.tets[tc / 4];
  const int c = int(tc % 4);
  std::array<uint32_t, 3> f = {v[size_t(kFace[c][0])], v[size_t(kFace[c][1])], v[size_t(kFace[c][2])]};
  const glm::dvec3 n = glm::cross(T.points[f[1]] - T.points[f[0]], T.points[f[2]] - T.points[f[0]]);
  if (glm::dot(n, T.points[v[size_t(c)]] - T.points[f[0]]) > 0) std::swap(f[1], f[2]);
  return f;
}

std::vector<uint16_t> label_tets(const fields::IndicatorFields& F, const Tets& T) {
  std::vector<uint16_t> m(T.tets.size());
  const glm::dvec3 hi = glm::dvec3(F.grid.dims - 1);
  tbb::parallel_for(size_t(0), T.tets.size(), [&](size_t t) {
    const auto& v = T.tets[t];
    bool ok;
    const glm::dvec3 c = circumcentre(T.points[v[0]], T.points[v[1]], T.points[v[2]], T.points[v[3]], ok);
    m[t] = uint16_t(F.material_at(glm::clamp(c / F.grid.spacing, glm::dvec3(0.0), hi)));
  });
  return m;
}

std::vector<uint16_t> hull_materials(const fields::IndicatorFields& F, const Tets& T, const Adjacency& adj) {
  std::vector<uint16_t> out(adj.neighbour.size(), 0);
  const double h = F.grid.min_spacing();
  const glm::dvec3 hi = glm::dvec3(F.grid.dims - 1);
  for (uint32_t tc = 0; tc < adj.neighbour.size(); ++tc) {
    if (adj.neighbour[tc] != Adjacency::kHull) continue;
    const auto f = outward_face(T, tc);
    const glm::dvec3 &a = T.points[f[0]], &b = T.points[f[1]], &c = T.points[f[2]];
    const glm::dvec3 centroid = (a + b + c) / 3.0;
    const glm::dvec3 n = glm::normalize(glm::cross(b - a, c - a));
    // A surface sampled by this face's corners, with curvature radius no smaller than the face's circumradius rho,
    // bulges at most rho beyond it: sampling half a voxel out, as before, landed inside a material wherever a
    // large hull face cut under a curved surface, and the outside then changed material from face to face, which
    // left the materials' boundaries open (a 40^3 wedge ball lost its tet mesh that way).
    const double la = glm::length(b - c), lb = glm::length(c - a), lc = glm::length(a - b);
    const double area2 = glm::length(glm::cross(b - a, c - a));  // twice the area
    const double rho = area2 > 0 ? la * lb * lc / (2.0 * area2) : std::max({la, lb, lc});
    const double step = 0.5 * h + std::min(rho, 4.0 * h);
    out[tc] = uint16_t(F.material_at(glm::clamp((centroid + step * n) / F.grid.spacing, glm::dvec3(0.0), hi)));
  }
  return out;
}

uint16_t material_across(const Adjacency& adj, const std::vector<uint16_t>& hull, const std::vector<uint16_t>& material,
                         uint32_t tc) {
  return adj.neighbour[tc] == Adjacency::kHull ? hull[tc] : material[adj.neighbour[tc] / 4];
}

bool face_is_wrong(const Tets& T, uint32_t tc, uint16_t m, uint16_t o, const std::vector<uint64_t>& vertex_materials) {
  if (m == o) return false;
  const uint64_t need = (uint64_t(1) << (m & 63)) | (uint64_t(1) << (o & 63));
  const auto& v = T.tets[tc / 4];
  const int c = int(tc % 4);
  for (int k = 0; k < 3; ++k)
    if ((vertex_materials[v[size_t(kFace[c][k])]] & need) != need) return true;
  return false;
}

size_t repair_labels(const Tets& T, const Adjacency& adj, const std::vector<uint16_t>& hull,
                     const std::vector<uint64_t>& vertex_materials, std::vector<uint16_t>& material, int passes) {
  auto other = [&](uint32_t tc) { return material_across(adj, hull, material, tc); };
  auto cost = [&](uint32_t t, uint16_t m) {
    int n = 0;
    for (uint32_t c = 0; c < 4; ++c) n += face_is_wrong(T, t * 4 + c, m, other(t * 4 + c), vertex_materials);
    return n;
  };
  size_t changed = 0;
  for (int pass = 0; pass < passes; ++pass) {
    size_t changes = 0;
    for (uint32_t t = 0; t < T.tets.size(); ++t) {
      const int now = cost(t, material[t]);
      if (now == 0) continue;
      int best = now;
      uint16_t best_m = material[t];
      // Candidates: the neighbours' materials and every material a vertex of the tet lies on.
      uint64_t candidates = 0;
      for (uint32_t c = 0; c < 4; ++c) candidates |= uint64_t(1) << (other(t * 4 + c) & 63);
      for (uint32_t v : T.tets[t]) candidates |= vertex_materials[v];
      for (uint16_t m = 0; m < 64; ++m) {
        if (!(candidates >> m & 1) || m == material[t]) continue;
        const int k = cost(t, m);
        if (k < best) {
          best = k;
          best_m = m;
        }
      }
      if (best_m != material[t]) {
        material[t] = best_m;
        ++changes;
      }
    }
    changed += changes;
    if (changes == 0) break;
  }
  return changed;
}

std::vector<uint32_t> wrong_faces(const Tets& T, const Adjacency& adj, const std::vector<uint16_t>& hull,
                                  const std::vector<uint64_t>& vertex_materials, const std::vector<uint16_t>& material) {
  std::vector<uint32_t> out;
  for (uint32_t tc = 0; tc < adj.neighbour.size(); ++tc) {
    const uint32_t nb = adj.neighbour[tc];
    if (nb != Adjacency::kHull && nb < tc) continue;  // each shared face once
    if (face_is_wrong(T, tc, material[tc / 4], material_across(adj, hull, material, tc), vertex_materials)) out.push_back(tc);
  }
  return out;
}

InterfaceMesh extract_interfaces(const Tets& T, const Adjacency& adj, const std::vector<uint16_t>& hull,
                                 const std::vector<uint16_t>& material, const std::vector<uint8_t>& vertex_kind) {
  InterfaceMesh out;
  out.vertices = T.points;
  out.vertex_kind = vertex_kind;
  for (uint32_t tc = 0; tc < adj.neighbour.size(); ++tc) {
    const uint32_t nb = adj.neighbour[tc];
    if (nb != Adjacency::kHull && nb < tc) continue;  // each shared face once
    const uint16_t ma = material[tc / 4], mb = material_across(adj, hull, material, tc);
    if (ma == mb) continue;
    // Oriented out of the smaller material's side, so the normal points into the larger one.
    auto f = outward_face(T, tc);
    if (ma > mb) std::swap(f[1], f[2]);
    out.triangles.push_back(f);
    out.pair.push_back({std::min(ma, mb), std::max(ma, mb)});
  }
  return out;
}

std::vector<uint32_t> component_representatives(const Tets& T, const Adjacency& adj, const std::vector<uint16_t>& hull,
                                                const std::vector<uint16_t>& material) {
  std::vector<uint32_t> parent(T.tets.size());
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (uint32_t tc = 0; tc < adj.neighbour.size(); ++tc) {
    const uint32_t nb = adj.neighbour[tc];
    if (nb != Adjacency::kHull && material[tc / 4] == material[nb / 4]) parent[find(tc / 4)] = find(nb / 4);
  }
  // Per component, its tet with the largest inscribed sphere: the volume mesher takes the centroid as the region's
  // seed point, which must stay inside the region when the surface is smoothed afterwards.
  std::vector<double> best(T.tets.size(), -1.0);
  std::vector<uint32_t> rep_of(T.tets.size(), ~0u);
  for (uint32_t t = 0; t < T.tets.size(); ++t) {
    const auto& k = T.tets[t];
    const glm::dvec3 &a = T.points[k[0]], &b = T.points[k[1]], &c = T.points[k[2]], &d = T.points[k[3]];
    const double volume = tet_volume(a, b, c, d);
    const double area = 0.5 * (glm::length(glm::cross(b - a, c - a)) + glm::length(glm::cross(b - a, d - a)) +
                               glm::length(glm::cross(c - a, d - a)) + glm::length(glm::cross(c - b, d - b)));
    const double inradius = area > 0 ? 3.0 * volume / area : 0.0;
    const uint32_t root = find(t);
    if (inradius > best[root]) best[root] = inradius, rep_of[root] = t;
  }
  // Components open to the outside (a hull face with the same material beyond it, so no interface triangle there) are
  // outside every closed interface: the volume mesher drops them as exterior, and a seed there (a flat hull tet,
  // moved by the smoothing) could land inside a region and relabel it.
  std::vector<uint8_t> unbounded(T.tets.size(), 0);
  for (uint32_t tc = 0; tc < adj.neighbour.size(); ++tc)
    if (adj.neighbour[tc] == Adjacency::kHull && material_across(adj, hull, material, tc) == material[tc / 4])
      unbounded[find(tc / 4)] = 1;
  std::vector<uint32_t> reps;
  for (uint32_t t = 0; t < T.tets.size(); ++t)
    if (find(t) == t && !unbounded[t]) reps.push_back(rep_of[t]);
  return reps;
}

}  // namespace cpmesh::mesh
