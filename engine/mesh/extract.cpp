#include "mesh/extract.h"

#include "mesh/quality.h"

#include <algorithm>
#include <atomic>
#include <limits>
#include <set>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "host/disjoint_sets.h"
#include "host/host_array.h"

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

std::array<uint32_t, 3> outward_face(const Tets& T, uint32_t tc) {
  const auto& v = T.tets[tc / 4];
  const int c = int(tc % 4);
  std::array<uint32_t, 3> f = {v[size_t(kFace[c][0])], v[size_t(kFace[c][1])], v[size_t(kFace[c][2])]};
  const glm::dvec3 n = glm::cross(T.points[f[1]] - T.points[f[0]], T.points[f[2]] - T.points[f[0]]);
  if (glm::dot(n, T.points[v[size_t(c)]] - T.points[f[0]]) > 0) std::swap(f[1], f[2]);
  return f;
}

glm::dvec3 label_point(const Tets& T, uint32_t t) {
  const auto& v = T.tets[t];
  bool ok;
  return circumcentre(T.points[v[0]], T.points[v[1]], T.points[v[2]], T.points[v[3]], ok);
}

uint16_t label_tet(const fields::IndicatorFields& F, const Tets& T, uint32_t t) {
  return uint16_t(F.material_at(glm::clamp(label_point(T, t) / F.grid.spacing, glm::dvec3(0.0), glm::dvec3(F.grid.dims - 1))));
}

std::vector<uint16_t> label_tets(const fields::IndicatorFields& F, const Tets& T) {
  std::vector<uint16_t> m(T.tets.size());
  tbb::parallel_for(size_t(0), T.tets.size(), [&](size_t t) { m[t] = label_tet(F, T, uint32_t(t)); });
  return m;
}

glm::dvec3 hull_sample_point(const fields::IndicatorFields& F, const Tets& T, uint32_t tc) {
  const double h = F.grid.min_spacing();
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
  return centroid + (0.5 * h + std::min(rho, 4.0 * h)) * n;
}

std::vector<uint16_t> hull_materials(const fields::IndicatorFields& F, const Tets& T, const Adjacency& adj) {
  std::vector<uint16_t> out(adj.neighbour.size(), 0);
  const glm::dvec3 hi = glm::dvec3(F.grid.dims - 1);
  const tbb::blocked_range<uint32_t> faces(0, uint32_t(adj.neighbour.size()), 1 << 14);
  tbb::parallel_for(faces, [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t tc = r.begin(); tc < r.end(); ++tc)
      if (adj.neighbour[tc] == Adjacency::kHull)
        out[tc] = uint16_t(F.material_at(glm::clamp(hull_sample_point(F, T, tc) / F.grid.spacing, glm::dvec3(0.0), hi)));
  });
  return out;
}

uint16_t material_across(const Adjacency& adj, const std::vector<uint16_t>& hull, const std::vector<uint16_t>& material,
                         uint32_t tc) {
  return adj.neighbour[tc] == Adjacency::kHull ? hull[tc] : material[adj.neighbour[tc] / 4];
}

bool face_is_wrong(const Tets& T, uint32_t tc, uint16_t m, uint16_t o, const std::vector<fields::MaterialList>& vertex_materials) {
  if (m == o) return false;
  const auto& v = T.tets[tc / 4];
  const int c = int(tc % 4);
  for (int k = 0; k < 3; ++k) {
    const fields::MaterialList& s = vertex_materials[v[size_t(kFace[c][k])]];
    if (!s.has(m) || !s.has(o)) return true;
  }
  return false;
}

size_t repair_labels(const Tets& T, const Adjacency& adj, const std::vector<uint16_t>& hull,
                     const std::vector<fields::MaterialList>& vertex_materials, std::vector<uint16_t>& material, int passes) {
  auto other = [&](uint32_t tc) { return material_across(adj, hull, material, tc); };
  auto cost = [&](uint32_t t, uint16_t m) {
    int n = 0;
    for (uint32_t c = 0; c < 4; ++c) n += face_is_wrong(T, t * 4 + c, m, other(t * 4 + c), vertex_materials);
    return n;
  };
  // Each pass visits the tets in order and relabels one as soon as a better material is found, so a tet sees its
  // lower-numbered neighbours' new labels. Only a tet with a wrong face can change, and one has a wrong face at its
  // visit only if it had one when the pass began or a neighbour changed before it: those (found in parallel), and
  // the higher-numbered neighbours of each change, are visited in order: the serial pass over every tet, exactly.
  const uint32_t nt = uint32_t(T.tets.size());
  size_t changed = 0;
  std::vector<uint8_t> has_wrong(nt);
  for (int pass = 0; pass < passes; ++pass) {
    size_t changes = 0;
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, nt, 1 << 14), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t t = r.begin(); t < r.end(); ++t) has_wrong[t] = uint8_t(cost(t, material[t]) > 0);
    });
    std::vector<uint32_t> start;
    for (uint32_t t = 0; t < nt; ++t)
      if (has_wrong[t]) start.push_back(t);
    std::set<uint32_t> later;  // neighbours of changed tets, after the one being visited
    size_t next = 0;
    for (;;) {
      uint32_t t;
      const bool from_start = next < start.size() && (later.empty() || start[next] <= *later.begin());
      if (from_start) {
        t = start[next++];
        if (!later.empty() && *later.begin() == t) later.erase(later.begin());
      } else if (!later.empty()) {
        t = *later.begin();
        later.erase(later.begin());
      } else {
        break;
      }
      const int now = cost(t, material[t]);
      if (now == 0) continue;
      int best = now;
      uint16_t best_m = material[t];
      // Candidates: the neighbours' materials and every material a vertex of the tet lies on.
      const std::array<fields::MaterialList, 4> around = {vertex_materials[T.tets[t][0]], vertex_materials[T.tets[t][1]],
                                                         vertex_materials[T.tets[t][2]], vertex_materials[T.tets[t][3]]};
      for (uint16_t m : fields::union_of(around, {other(t * 4), other(t * 4 + 1), other(t * 4 + 2), other(t * 4 + 3)})) {
        if (m == material[t]) continue;
        const int k = cost(t, m);
        if (k < best) {
          best = k;
          best_m = m;
        }
      }
      if (best_m != material[t]) {
        material[t] = best_m;
        ++changes;
        for (uint32_t c = 0; c < 4; ++c) {
          const uint32_t nb = adj.neighbour[t * 4 + c];
          if (nb != Adjacency::kHull && nb / 4 > t) later.insert(nb / 4);
        }
      }
    }
    changed += changes;
    if (changes == 0) break;
  }
  return changed;
}

std::vector<uint32_t> wrong_faces(const Tets& T, const Adjacency& adj, const std::vector<uint16_t>& hull,
                                  const std::vector<fields::MaterialList>& vertex_materials, const std::vector<uint16_t>& material) {
  // Chunks of faces in parallel, joined in order: the faces in ascending order, as one loop finds them.
  return collect_in_order_by_index<uint32_t>(adj.neighbour.size(), size_t(1) << 16, [&](size_t i, auto& out) {
    const uint32_t tc = uint32_t(i), nb = adj.neighbour[tc];
    if (nb != Adjacency::kHull && nb < tc) return;  // each shared face once
    if (face_is_wrong(T, tc, material[tc / 4], material_across(adj, hull, material, tc), vertex_materials))
      out.push_back(tc);
  });
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
    out.face.push_back(tc);
  }
  return out;
}

std::vector<uint32_t> component_representatives(const Tets& T, const Adjacency& adj, const std::vector<uint16_t>& hull,
                                                const std::vector<uint16_t>& material) {
  // Components of face-adjacent tets of one material, joined on every thread; a component's root is its first tet.
  const size_t n = T.tets.size();
  DisjointSets sets(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, adj.neighbour.size(), size_t(1) << 14),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t tc = r.begin(); tc != r.end(); ++tc) {
                        const uint32_t nb = adj.neighbour[tc];
                        if (nb != Adjacency::kHull && nb / 4 > tc / 4 && material[tc / 4] == material[nb / 4])
                          sets.join(uint32_t(tc / 4), nb / 4);
                      }
                    });
  // Per tet, its root and inscribed sphere's radius. Per component, its tet with the largest inscribed sphere (the
  // first such): the volume mesher takes the centroid as the region's seed point, which must stay inside the region
  // when the surface is smoothed afterwards.
  HostArray<uint32_t> root(n);
  HostArray<double> inradius(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, size_t(1) << 14), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t) {
      const auto& k = T.tets[t];
      const glm::dvec3 &a = T.points[k[0]], &b = T.points[k[1]], &c = T.points[k[2]], &d = T.points[k[3]];
      const double volume = tet_volume(a, b, c, d);
      const double area = 0.5 * (glm::length(glm::cross(b - a, c - a)) + glm::length(glm::cross(b - a, d - a)) +
                                 glm::length(glm::cross(c - a, d - a)) + glm::length(glm::cross(c - b, d - b)));
      const double r = area > 0 ? 3.0 * volume / area : 0.0;
      inradius[t] = r == r ? r : -std::numeric_limits<double>::infinity();  // a non-finite tet never represents
      root[t] = sets.find(uint32_t(t));
    }
  });
  // A root is its component's first tet, so each component's best starts there.
  HostArray<double> best(n);
  HostArray<uint32_t> rep_of(n);
  for (size_t t = 0; t < n; ++t) {
    const uint32_t c = root[t];
    if (c == t || inradius[t] > best[c]) best[c] = inradius[t], rep_of[c] = uint32_t(t);
  }
  // Components open to the outside (a hull face with the same material beyond it, so no interface triangle there) are
  // outside every closed interface: the volume mesher drops them as exterior, and a seed there (a flat hull tet,
  // moved by the smoothing) could land inside a region and relabel it.
  HostArray<uint8_t> unbounded = filled(n, uint8_t(0));
  tbb::parallel_for(tbb::blocked_range<size_t>(0, adj.neighbour.size(), size_t(1) << 14),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t tc = r.begin(); tc != r.end(); ++tc)
                        if (opens_to_outside(adj, hull, material, uint32_t(tc)))
                          std::atomic_ref<uint8_t>(unbounded[root[tc / 4]]).store(1, std::memory_order_relaxed);
                    });
  std::vector<uint32_t> reps;
  for (size_t t = 0; t < n; ++t)
    if (root[t] == t && !unbounded[t]) reps.push_back(rep_of[t]);
  return reps;
}

size_t promote_junction_vertices(InterfaceMesh& mesh, const std::vector<fields::MaterialList>& vertex_materials,
                                 std::vector<uint8_t>& kind) {
  std::vector<std::vector<uint16_t>> touched(mesh.vertices.size());
  for (size_t t = 0; t < mesh.triangles.size(); ++t)
    for (uint32_t v : mesh.triangles[t]) touched[v].insert(touched[v].end(), mesh.pair[t].begin(), mesh.pair[t].end());
  size_t promoted = 0;
  for (size_t v = 0; v < touched.size(); ++v) {
    auto& ms = touched[v];
    std::sort(ms.begin(), ms.end());
    ms.erase(std::unique(ms.begin(), ms.end()), ms.end());
    const size_t holds = 4 - size_t(kind[v]);  // FeatureKind: 0 point (4 materials), 1 curve (3), 2 interface (2)
    if (ms.size() <= holds || kind[v] == 0) continue;  // a quadruple point already holds any number
    if (!std::all_of(ms.begin(), ms.end(), [&](uint16_t m) { return vertex_materials[v].has(m); })) continue;
    kind[v] = mesh.vertex_kind[v] = uint8_t(ms.size() >= 4 ? 0 : 4 - ms.size());
    ++promoted;
  }
  return promoted;
}

}  // namespace cpmesh::mesh
