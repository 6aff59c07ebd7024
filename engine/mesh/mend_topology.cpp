#include "mesh/mend_topology.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <set>
#include <utility>

#include "fields/closest_point_embedding.h"
#include "mesh/elements_around.h"
#include "mesh/extract.h"
#include "mesh/face_key.h"
#include "mesh/refine.h"

namespace cpmesh::mesh {

namespace {

using Edge = std::pair<uint32_t, uint32_t>;  // vertex indices, first < second

class Faults {
 public:
  Faults(const Tets& T, const Adjacency& adj, const std::vector<uint16_t>& hull,
          const std::vector<fields::MaterialList>& vertex_materials, const std::vector<uint8_t>& kind,
          std::vector<uint16_t>& material)
      : T_(T), adj_(adj), hull_(hull), vm_(vertex_materials), kind_(kind), material_(material) {}

  // The edges with an excess (of the faces nonmanifold_faces reports), and the edges of the wrong faces.
  std::vector<Edge> faulty() const {
    std::set<Edge> out;
    auto add_edges = [&](uint32_t tc, bool only_excess) {
      const auto f = outward_face(T_, tc);
      for (int k = 0; k < 3; ++k) {
        const Edge e = std::minmax(f[size_t(k)], f[size_t((k + 1) % 3)]);
        if (!only_excess || excess(e) > 0) out.insert(e);
      }
    };
    for (uint32_t tc : nonmanifold_faces(extract_interfaces(T_, adj_, hull_, material_, kind_))) add_edges(tc, true);
    for (uint32_t tc : wrong_faces(T_, adj_, hull_, vm_, material_)) add_edges(tc, false);
    return {out.begin(), out.end()};
  }

  int excess(const Edge& e) const {
    std::vector<std::pair<uint32_t, int>> count;  // interface (pair key), triangles around e
    int total = 0;
    for (uint32_t tc : faces_around(e)) {
      const uint16_t m = material_[tc / 4], o = material_across(adj_, hull_, material_, tc);
      if (m == o) continue;
      const uint32_t key = pair_key(m, o);
      auto it = std::find_if(count.begin(), count.end(), [&](const auto& c) { return c.first == key; });
      if (it == count.end()) count.push_back({key, 1});
      else ++it->second;
      ++total;
    }
    const auto interface_kind = uint8_t(fields::FeatureKind::interface);
    const bool on_junctions = kind_[e.first] != interface_kind && kind_[e.second] != interface_kind;
    int n = 0;
    for (const auto& [key, c] : count) n += edge_excess(size_t(c), size_t(total), on_junctions);
    return n;
  }

  // The vertices of the wrong faces that lack one of the face's materials.
  std::vector<uint32_t> wrong_vertices() const {
    std::set<uint32_t> out;
    for (uint32_t tc : wrong_faces(T_, adj_, hull_, vm_, material_)) {
      const uint16_t m = material_[tc / 4], o = material_across(adj_, hull_, material_, tc);
      for (uint32_t v : outward_face(T_, tc))
        if (!vm_[v].has(m) || !vm_[v].has(o)) out.insert(v);
    }
    return {out.begin(), out.end()};
  }

  // Relabels the best run of tets around e (mend_topology.h); how many tets.
  size_t mend(const Edge& e) {
    Choice best;
    for (const auto& run : runs(e, tets_around(e)))
      for (uint16_t to : neighbour_materials(e, run)) consider(run, to, best);
    return apply(best);
  }

  // A vertex of a wrong face: its tets of materials it does not lie on, relabelled together with one it lies on.
  size_t mend(uint32_t v) {
    std::vector<uint32_t> off;
    for (uint32_t t : around()[v])
      if (!vm_[v].has(material_[t])) off.push_back(t);
    Choice best;
    if (!off.empty())
      for (uint16_t to : vm_[v].members()) consider(off, to, best);
    return apply(best);
  }

 private:
  std::vector<uint32_t> tets_around(const Edge& e) const {
    std::vector<uint32_t> out;
    for (uint32_t t : around()[e.first])
      if (has_vertex(T_.tets[t], e.second)) out.push_back(t);
    return out;
  }

  // A face once for its two sides: the smaller of its two tet-corner indices (a hull face as it is).
  uint32_t shared_face(uint32_t tc) const {
    const uint32_t nb = adj_.neighbour[tc];
    return nb == Adjacency::kHull ? tc : std::min(tc, nb);
  }

  // The faces holding e, each once.
  std::vector<uint32_t> faces_around(const Edge& e) const {
    std::vector<uint32_t> out;
    for (uint32_t t : tets_around(e))
      for (uint32_t c = 0; c < 4; ++c) {
        const uint32_t v = T_.tets[t][c];
        if (v == e.first || v == e.second) continue;  // the face opposite a corner of e does not hold e
        out.push_back(shared_face(t * 4 + c));
      }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }

  struct Choice {
    int gain = 0;
    double volume = 0;
    std::vector<uint32_t> tets;
    uint16_t to = 0;
  };

  // Keeps relabelling `tets` with `to` in `best` where it removes faults, adds none, and removes more than `best`
  // (or as many, in less volume).
  void consider(const std::vector<uint32_t>& tets, uint16_t to, Choice& best) {
    const auto [less_excess, less_wrong] = try_relabel(tets, to);
    const int gain = less_excess + less_wrong;
    if (less_excess < 0 || less_wrong < 0 || gain <= 0 || gain < best.gain) return;
    const double v = volume(tets);
    if (gain == best.gain && v >= best.volume) return;
    best = {gain, v, tets, to};
  }

  size_t apply(const Choice& c) {
    for (uint32_t t : c.tets) material_[t] = c.to;
    return c.tets.size();
  }

  // The runs around e: the tets joined, through their faces that hold e, to neighbours of their own material.
  std::vector<std::vector<uint32_t>> runs(const Edge& e, const std::vector<uint32_t>& ring) const {
    std::vector<size_t> parent(ring.size());
    std::iota(parent.begin(), parent.end(), size_t(0));
    auto find = [&](size_t i) {
      while (parent[i] != i) i = parent[i] = parent[parent[i]];
      return i;
    };
    auto index_of = [&](uint32_t t) { return size_t(std::find(ring.begin(), ring.end(), t) - ring.begin()); };
    for (uint32_t tc : faces_around(e)) {
      const uint32_t nb = adj_.neighbour[tc];
      if (nb == Adjacency::kHull || material_[tc / 4] != material_[nb / 4]) continue;
      parent[find(index_of(tc / 4))] = find(index_of(nb / 4));
    }
    std::vector<std::vector<uint32_t>> out;
    std::vector<size_t> slot(ring.size(), SIZE_MAX);
    for (size_t i = 0; i < ring.size(); ++i) {
      const size_t r = find(i);
      if (slot[r] == SIZE_MAX) slot[r] = out.size(), out.emplace_back();
      out[slot[r]].push_back(ring[i]);
    }
    return out;
  }

  // The materials across the run's faces that hold e, other than its own.
  std::vector<uint16_t> neighbour_materials(const Edge& e, const std::vector<uint32_t>& run) const {
    std::vector<uint16_t> out;
    for (uint32_t t : run)
      for (uint32_t c = 0; c < 4; ++c) {
        const uint32_t v = T_.tets[t][c];
        if (v == e.first || v == e.second) continue;
        const uint16_t o = material_across(adj_, hull_, material_, t * 4 + c);
        if (o != material_[t] && std::find(out.begin(), out.end(), o) == out.end()) out.push_back(o);
      }
    return out;
  }

  // The excess removed over every edge of the run's tets, and the wrong faces removed, by relabelling it `to`
  // (the labels are restored).
  std::pair<int, int> try_relabel(const std::vector<uint32_t>& run, uint16_t to) {
    std::set<Edge> edges;
    std::set<uint32_t> faces;
    for (uint32_t t : run) {
      for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) edges.insert(std::minmax(T_.tets[t][size_t(i)], T_.tets[t][size_t(j)]));
      for (uint32_t c = 0; c < 4; ++c) faces.insert(shared_face(t * 4 + c));
    }
    auto measure = [&] {
      int ex = 0, wrong = 0;
      for (const Edge& e : edges) ex += excess(e);
      for (uint32_t tc : faces)
        wrong += face_is_wrong(T_, tc, material_[tc / 4], material_across(adj_, hull_, material_, tc), vm_);
      return std::pair{ex, wrong};
    };
    std::vector<uint16_t> from;
    for (uint32_t t : run) from.push_back(material_[t]);
    const auto [ex0, wrong0] = measure();
    for (uint32_t t : run) material_[t] = to;
    const auto [ex1, wrong1] = measure();
    for (size_t i = 0; i < run.size(); ++i) material_[run[i]] = from[i];
    return {ex0 - ex1, wrong0 - wrong1};
  }

  double volume(const std::vector<uint32_t>& run) const {
    double v = 0;
    for (uint32_t t : run) {
      const auto& q = T_.tets[t];
      const glm::dvec3 p = T_.points[q[0]];
      v += std::abs(glm::dot(T_.points[q[1]] - p, glm::cross(T_.points[q[2]] - p, T_.points[q[3]] - p))) / 6.0;
    }
    return v;
  }

  const Tets& T_;
  const Adjacency& adj_;
  const std::vector<uint16_t>& hull_;
  const std::vector<fields::MaterialList>& vm_;
  const std::vector<uint8_t>& kind_;
  std::vector<uint16_t>& material_;
  // The tets around each point, built at the first fault (most meshes have none).
  const ElementsAround<4>& around() const {
    if (!around_) around_.emplace(T_.points.size(), T_.tets);
    return *around_;
  }
  mutable std::optional<ElementsAround<4>> around_;
};

}  // namespace

TopologyMendReport mend_topology(const Tets& tets, const Adjacency& adj, const std::vector<uint16_t>& hull,
                                 const std::vector<fields::MaterialList>& vertex_materials,
                                 const std::vector<uint8_t>& vertex_kind, std::vector<uint16_t>& material, int passes) {
  Faults f(tets, adj, hull, vertex_materials, vertex_kind, material);
  TopologyMendReport rep;
  std::vector<Edge> edges = f.faulty();
  rep.edges = edges.size();
  for (int pass = 0; pass < passes && !edges.empty(); ++pass) {
    size_t changed = 0;
    for (const Edge& e : edges) changed += f.mend(e);
    for (uint32_t v : f.wrong_vertices()) changed += f.mend(v);
    rep.relabelled += changed;
    edges = f.faulty();
    if (changed == 0) break;
  }
  rep.left = edges.size();
  return rep;
}

}  // namespace cpmesh::mesh
