// mesh::mend_topology (mend_topology.h): four tets around one edge, labelled 1, 2, 1, 2 in turn, pinch interface 1/2
// at that edge (four triangles): relabelling one run joins two of the others and leaves the edge in two triangles. A
// slab far thinner than its sampling: fewer pinched edges after, counted by a plain loop, and no more wrong faces.
// mesh::wrong_vertex_junctions (refine.h): an interface vertex of a wrong face beside a triple curve goes onto the curve.
#include <doctest/doctest.h>

#include <algorithm>
#include <map>
#include <random>
#include <tuple>

#include "fields/closest_point_embedding.h"
#include "mesh/delaunay.h"
#include "mesh/adjacency.h"
#include "mesh/extract.h"
#include "mesh/mend_topology.h"
#include "mesh/refine.h"
#include "fields_volumes.h"
#include "ball_points.h"

using namespace cpmesh;

namespace {

// The edge a-b (points 0 and 1) with four points around it; every hull face takes material 3 outside, and every
// point lies on a triple curve of 1, 2 and 3 unless `materials` says otherwise.
struct Ring {
  mesh::Tets T;
  mesh::Adjacency adj;
  std::vector<uint16_t> hull, material{1, 2, 1, 2};
  std::vector<fields::MaterialList> materials;
  std::vector<uint8_t> kind;
  Ring() {
    T.points = {{0, 0, -0.5}, {0, 0, 0.5}, {2, 0, 0}, {0, 2, 0}, {-2, 0, 0}, {0, -2, 0}};
    T.tets = {{0, 1, 2, 3}, {0, 1, 3, 4}, {0, 1, 4, 5}, {0, 1, 5, 2}};
    adj = mesh::build_adjacency(T);
    hull.assign(adj.neighbour.size(), 0);
    for (size_t tc = 0; tc < hull.size(); ++tc)
      if (adj.neighbour[tc] == mesh::Adjacency::kHull) hull[tc] = 3;
    materials.assign(T.points.size(), fields::MaterialList(std::vector<uint16_t>{1, 2, 3}));
    kind.assign(T.points.size(), uint8_t(fields::FeatureKind::triple_curve));
  }
  // Interface 1/2's triangles holding points 0 and 1.
  int triangles_at_edge() const {
    const auto I = mesh::extract_interfaces(T, adj, hull, material, kind);
    int n = 0;
    for (size_t t = 0; t < I.triangles.size(); ++t) {
      const auto& f = I.triangles[t];
      const bool has0 = f[0] == 0 || f[1] == 0 || f[2] == 0, has1 = f[0] == 1 || f[1] == 1 || f[2] == 1;
      n += has0 && has1 && I.pair[t] == std::array<uint16_t, 2>{1, 2};
    }
    return n;
  }
};

}  // namespace

TEST_CASE("mend_topology: an edge in four triangles of one interface is left in two, by one tet relabelled") {
  Ring r;
  REQUIRE(r.triangles_at_edge() == 4);
  const mesh::TopologyMendReport rep = mesh::mend_topology(r.T, r.adj, r.hull, r.materials, r.kind, r.material);
  CHECK(rep.edges == 1);
  CHECK(rep.relabelled == 1);
  CHECK(rep.left == 0);
  CHECK(r.triangles_at_edge() == 2);
  CHECK(mesh::wrong_faces(r.T, r.adj, r.hull, r.materials, r.material).empty());
}

// Interface edges in more than two triangles of their interface, counted by a plain map over the triangles.
size_t edges_in_more_than_two(const mesh::InterfaceMesh& I) {
  std::map<std::tuple<uint32_t, uint32_t, uint32_t>, int> count;
  for (size_t t = 0; t < I.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const auto [a, b] = std::minmax(I.triangles[t][size_t(k)], I.triangles[t][size_t((k + 1) % 3)]);
      ++count[{a, b, uint32_t(I.pair[t][0]) << 16 | I.pair[t][1]}];
    }
  return size_t(std::count_if(count.begin(), count.end(), [](const auto& c) { return c.second > 2; }));
}

TEST_CASE("mend_topology: a sheet thinner than the sampling, pinched at many edges, with fewer pinches and no "
          "more wrong faces after") {
  // Random points in a ball; material 2 in a slab 0.02 thick (far thinner than the points' spacing) inside 1,
  // labelled at the tets' centroids; points within 0.1 of the slab lie on interface 1/2, others on their side's
  // material only, so a relabelling far from the slab would make wrong faces.
  std::mt19937 rng(5);
  const std::vector<glm::dvec3> points = test::points_in_ball(4000, rng);
  const auto in_slab = [](const glm::dvec3& p) { return std::abs(p.z - 0.1 * p.x) < 0.01; };
  std::vector<fields::MaterialList> materials(points.size());
  std::vector<uint8_t> kind(points.size(), uint8_t(fields::FeatureKind::interface));
  for (size_t v = 0; v < points.size(); ++v)
    materials[v] = fields::MaterialList(std::abs(points[v].z - 0.1 * points[v].x) < 0.1 ? std::vector<uint16_t>{1, 2}
                                        : std::vector<uint16_t>{1});
  mesh::DelaunayMesh dm(points);
  mesh::Adjacency adj;
  const mesh::Tets T = dm.tets(&adj);
  std::vector<uint16_t> material(T.tets.size());
  for (size_t t = 0; t < T.tets.size(); ++t) {
    material[t] = in_slab(test::centroid(T, t)) ? 2 : 1;
  }
  std::vector<uint16_t> hull(adj.neighbour.size(), 0);
  for (size_t tc = 0; tc < hull.size(); ++tc)
    if (adj.neighbour[tc] == mesh::Adjacency::kHull) hull[tc] = material[tc / 4];
  const size_t pinched_before = edges_in_more_than_two(mesh::extract_interfaces(T, adj, hull, material, kind));
  const size_t wrong_before = mesh::wrong_faces(T, adj, hull, materials, material).size();
  const mesh::TopologyMendReport rep = mesh::mend_topology(T, adj, hull, materials, kind, material);
  const size_t pinched_after = edges_in_more_than_two(mesh::extract_interfaces(T, adj, hull, material, kind));
  MESSAGE(T.tets.size() << " tets; pinched edges " << pinched_before << " -> " << pinched_after << ", "
                        << rep.relabelled << " tets relabelled; wrong faces " << wrong_before);
  REQUIRE(pinched_before > 10);
  CHECK(rep.relabelled > 0);
  CHECK(pinched_after < pinched_before / 2);
  CHECK(mesh::wrong_faces(T, adj, hull, materials, material).size() <= wrong_before);
}

TEST_CASE("wrong_vertex_junctions: an interface vertex of a wrong face a fifth of a voxel from the triple curve goes onto it; "
          "one a voxel away stays") {
  // Labels 1 (x < 8), 2 (x >= 8, y < 8) and 3 (x >= 8, y >= 8): interface 1/2 at x = 8 below y = 8, and the triple
  // curve of 1, 2 and 3 along z at about (7.5, 7.5) in voxel-centre coordinates.
  const io::LabelVolume vol = test::label_volume(16, 16, 16, [](int i, int j, int) { return i < 8 ? 1 : j < 8 ? 2 : 3; });
  const fields::Grid grid = fields::grid_of(vol);
  const auto F = fields::build_indicator_fields(grid, vol.labels.data());
  const auto E = fields::build_closest_point_embedding(F);
  auto index_of = [&](uint16_t label) { return uint16_t(std::find(F.labels.begin(), F.labels.end(), label) - F.labels.begin()); };
  const uint16_t m1 = index_of(1), m2 = index_of(2), m3 = index_of(3);
  std::array<uint16_t, 4> key = {0xffff, 0xffff, 0xffff, 0xffff};
  std::array<uint16_t, 3> mats = {m1, m2, m3};
  std::sort(mats.begin(), mats.end());
  std::copy(mats.begin(), mats.end(), key.begin());
  const int curve = E.feature_index(fields::FeatureKind::triple_curve, key);
  REQUIRE(curve >= 0);
  // A point of the curve at z = 8 (Newton from the voxel corner), and the interface 1/2's points beside it.
  glm::dvec3 on_curve;
  REQUIRE(fields::project_to_feature(F, E.features[size_t(curve)], glm::dvec3(7.5, 7.5, 8.0), on_curve));
  for (const double away : {0.2, 1.0}) {
    // Two tets, of materials 2 and 3, sharing the face (v, a, b): a and b on the interface 2/3, v on 1/2 only.
    mesh::Tets T;
    const glm::dvec3 v = on_curve - glm::dvec3(0, away, 0);
    T.points = {v, on_curve + glm::dvec3(1, 0, -1), on_curve + glm::dvec3(1, 0, 1), on_curve + glm::dvec3(1.5, -1, 0),
                on_curve + glm::dvec3(1.5, 1, 0)};
    T.tets = {{0, 1, 2, 3}, {0, 2, 1, 4}};
    const mesh::Adjacency adj = mesh::build_adjacency(T);
    std::vector<uint16_t> material{m2, m3}, hull(adj.neighbour.size(), 0);
    for (size_t tc = 0; tc < hull.size(); ++tc)
      if (adj.neighbour[tc] == mesh::Adjacency::kHull) hull[tc] = material[tc / 4];
    std::vector<fields::MaterialList> vm = {fields::MaterialList(std::vector<uint16_t>{m1, m2}),
                                            fields::MaterialList(std::vector<uint16_t>{m2, m3}),
                                            fields::MaterialList(std::vector<uint16_t>{m2, m3}),
                                            fields::MaterialList(std::vector<uint16_t>{m2}),
                                            fields::MaterialList(std::vector<uint16_t>{m3})};
    const std::vector<uint32_t> wrong = mesh::wrong_faces(T, adj, hull, vm, material);
    REQUIRE(wrong.size() == 1);
    const auto joins = mesh::wrong_vertex_junctions(F, E, T, adj, hull, material, wrong, std::vector<float>(5, 1.0f), vm);
    if (away > 0.5) {
      CHECK(joins.empty());
      continue;
    }
    REQUIRE(joins.size() == 1);
    CHECK(joins[0].first == 0);
    CHECK(joins[0].second.feature == uint32_t(curve));
    const glm::dvec3 to = joins[0].second.position;
    MESSAGE("closest point " << glm::length(to - v) << " voxel, to " << glm::length(to - on_curve) << " from the curve point");
    CHECK(fields::feature_distance(F, E.features[size_t(curve)], to) < 0.05);
    CHECK(glm::length(to - on_curve) < 0.1);
  }
}
