// mesh::repair_labels and mesh::wrong_faces (extract.h) against plain serial loops over every tet and face: the
// parallel versions visit only the tets that can change and split the faces among threads, and must give the same
// labels and the same faces in the same order.
#include <doctest/doctest.h>

#include <random>
#include <set>

#include <tbb/global_control.h>

#include "fields/closest_point_embedding.h"
#include "mesh/delaunay.h"
#include "mesh/extract.h"
#include "ball_points.h"

using namespace cpmesh;

namespace {

// repair_labels as one loop over every tet per pass (its definition).
size_t serial_repair(const mesh::Tets& T, const mesh::Adjacency& adj, const std::vector<uint16_t>& hull,
                     const std::vector<fields::MaterialList>& vertex_materials, std::vector<uint16_t>& material,
                     int passes) {
  auto other = [&](uint32_t tc) { return mesh::material_across(adj, hull, material, tc); };
  auto cost = [&](uint32_t t, uint16_t m) {
    int n = 0;
    for (uint32_t c = 0; c < 4; ++c) n += mesh::face_is_wrong(T, t * 4 + c, m, other(t * 4 + c), vertex_materials);
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
      std::set<uint16_t> candidates;
      for (uint32_t c = 0; c < 4; ++c) candidates.insert(other(t * 4 + c));
      for (uint32_t v : T.tets[t])
        for (uint16_t m : vertex_materials[v].members()) candidates.insert(m);
      for (uint16_t m : candidates) {
        if (m == material[t]) continue;
        const int k = cost(t, m);
        if (k < best) best = k, best_m = m;
      }
      if (best_m != material[t]) material[t] = best_m, ++changes;
    }
    changed += changes;
    if (changes == 0) break;
  }
  return changed;
}

}  // namespace

TEST_CASE("repair_labels and wrong_faces: the same labels and faces as serial loops over every tet and face") {
  // Random points in a ball; materials by regions, half the tets relabelled at random, vertices on their region and
  // up to two random materials: many wrong faces, relabels that make a later neighbour's faces wrong (without the
  // visits of those neighbours the 2- and 50-pass results differ from the serial ones), several passes. Material
  // indices run to 603: any number of materials.
  std::mt19937 rng(11);
  const std::vector<glm::dvec3> points = test::points_in_ball(6000, rng);
  const auto index = [](uint32_t k) { return uint16_t(k * 150 + 3); };
  const auto region = [&](const glm::dvec3& p) { return index((p.x > 0.1) + 2 * (p.y > -0.2) + (p.z > 0.3)); };
  std::vector<fields::MaterialList> vertex_materials(points.size());
  for (size_t v = 0; v < points.size(); ++v) {
    std::vector<uint16_t> m = {region(points[v])};
    for (int k = 0; k < 2; ++k)
      if (rng() % 2 == 0) m.push_back(index(rng() % 3));
    vertex_materials[v] = fields::MaterialSet(m);
  }
  mesh::DelaunayMesh dm(points);
  mesh::Adjacency adj;
  const mesh::Tets T = dm.tets(&adj);
  std::vector<uint16_t> material(T.tets.size());
  for (size_t t = 0; t < T.tets.size(); ++t) {
    material[t] = rng() % 2 == 0 ? index(rng() % 3) : region(test::centroid(T, t));
  }
  std::vector<uint16_t> hull(adj.neighbour.size(), 0);
  for (size_t tc = 0; tc < hull.size(); ++tc)
    if (adj.neighbour[tc] == mesh::Adjacency::kHull) hull[tc] = index(rng() % 3);

  // wrong_faces: every face once (the lower side of a shared face), ascending.
  std::vector<uint32_t> expected_wrong;
  for (uint32_t tc = 0; tc < adj.neighbour.size(); ++tc) {
    const uint32_t nb = adj.neighbour[tc];
    if (nb != mesh::Adjacency::kHull && nb < tc) continue;
    if (mesh::face_is_wrong(T, tc, material[tc / 4], mesh::material_across(adj, hull, material, tc), vertex_materials))
      expected_wrong.push_back(tc);
  }
  const auto wrong = mesh::wrong_faces(T, adj, hull, vertex_materials, material);
  MESSAGE(T.tets.size() << " tets, " << wrong.size() << " wrong faces");
  CHECK(wrong.size() > 1000);
  CHECK(wrong == expected_wrong);

  for (int passes : {1, 2, 50}) {
    std::vector<uint16_t> serial = material, parallel = material;
    const size_t serial_changed = serial_repair(T, adj, hull, vertex_materials, serial, passes);
    size_t parallel_changed = 0;
    {
      tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 4);
      parallel_changed = mesh::repair_labels(T, adj, hull, vertex_materials, parallel, passes);
    }
    MESSAGE(passes << " passes: " << serial_changed << " tets relabelled");
    CHECK(serial_changed > 100);
    CHECK(parallel_changed == serial_changed);
    CHECK(parallel == serial);
  }
}

TEST_CASE("promoted junction vertices: a vertex meeting more materials than its feature, all in its set") {
  constexpr auto kInterface = uint8_t(fields::FeatureKind::interface);
  constexpr auto kCurve = uint8_t(fields::FeatureKind::triple_curve);
  // Four triangles around vertex 0 between materials 1, 2, 3 and 4 (a line where four labels meet); vertex 0 is on
  // a triple curve of 1, 2, 3, vertex 1 on interface 1/2.
  mesh::InterfaceMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 4, 1}};
  m.pair = {{1, 2}, {2, 3}, {3, 4}, {1, 4}};
  m.face = {0, 1, 2, 3};
  std::vector<uint8_t> kind = {kCurve, kInterface, kInterface, kInterface, kInterface};
  m.vertex_kind = kind;
  std::vector<fields::MaterialList> sets = {fields::MaterialSet{1, 2, 3}, fields::MaterialSet{1, 2},
                                            fields::MaterialSet{2, 3}, fields::MaterialSet{3, 4},
                                            fields::MaterialSet{1, 4}};
  // Its own set lacks 4: nothing changes (the faces are wrong, and stay so for the checker).
  CHECK(mesh::promote_junction_vertices(m, sets, kind) == 0);
  CHECK(kind[0] == kCurve);
  // Widened by a junction near it (refine.h), it becomes a junction point of the mesh.
  sets[0] = fields::MaterialList(std::vector<uint16_t>{1, 2, 3, 4});
  CHECK(mesh::promote_junction_vertices(m, sets, kind) == 1);
  CHECK(kind[0] == uint8_t(fields::FeatureKind::quadruple_point));
  CHECK(m.vertex_kind[0] == kind[0]);
}
