// The Delaunay refinement's choice of faces (mesh/refine.h): the faces around an interface edge in more than two of
// its triangles, or open away from a triple curve, and none of a closed surface or of a sheet ending on a curve.
#include <doctest/doctest.h>

#include "mesh/refine.h"

using namespace cpmesh;
using namespace cpmesh::mesh;

namespace {

constexpr auto kInterface = uint8_t(fields::FeatureKind::interface);
constexpr auto kCurve = uint8_t(fields::FeatureKind::triple_curve);

// The surface of tetrahedron 0-1-2-3 between materials 0 and 1, face ids 10, 11, ...
InterfaceMesh closed_tetrahedron() {
  InterfaceMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  m.vertex_kind.assign(5, kInterface);
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  for (uint32_t t = 0; t < 4; ++t) {
    m.pair.push_back({0, 1});
    m.face.push_back(10 + t);
  }
  return m;
}

}  // namespace

TEST_CASE("refinement faces: none on a closed interface, all three around a fin") {
  InterfaceMesh m = closed_tetrahedron();
  CHECK(nonmanifold_faces(m).empty());
  m.triangles.push_back({1, 2, 4});  // a third triangle of interface 0/1 on edge 1-2
  m.pair.push_back({0, 1});
  m.face.push_back(20);
  // Edge 1-2 is in three triangles (10, 13, 20); the fin's other two edges are open off any curve.
  CHECK(nonmanifold_faces(m) == std::vector<uint32_t>{10, 13, 20});
}

TEST_CASE("pinched vertices: two closed surfaces of one interface touching at a junction vertex, every edge manifold") {
  InterfaceMesh m = closed_tetrahedron();
  m.vertex_kind[3] = kCurve;
  CHECK(pinched_vertex_faces(m).empty());
  // A second tetrahedron 3-5-6-7 of the same interface, sharing vertex 3 only; faces 20, 21, ...
  m.vertices.insert(m.vertices.end(), {{1, 0, 2}, {0, 1, 2}, {0, 0, 3}});
  m.vertex_kind.resize(8, kInterface);
  for (const auto& t : std::vector<std::array<uint32_t, 3>>{{3, 6, 5}, {3, 5, 7}, {3, 7, 6}, {5, 6, 7}}) {
    m.triangles.push_back(t);
    m.pair.push_back({0, 1});
    m.face.push_back(20 + uint32_t(m.face.size() - 4));
  }
  CHECK(nonmanifold_faces(m).empty());
  // Vertex 3's triangles: 11, 12, 13 of the first surface and 20, 21, 22 of the second, two fans.
  CHECK(pinched_vertex_faces(m) == std::vector<uint32_t>{11, 12, 13, 20, 21, 22});
  // At an interface vertex, a thin part's two sides meeting: left.
  m.vertex_kind[3] = kInterface;
  CHECK(pinched_vertex_faces(m).empty());
  // Of two interfaces, each one fan at vertex 3: no pinch.
  m.vertex_kind[3] = kCurve;
  for (size_t t = 4; t < 8; ++t) m.pair[t] = {0, 2};
  CHECK(pinched_vertex_faces(m).empty());
}

TEST_CASE("refinement faces: interfaces ending on a triple curve are right, ending on an interface vertex are not") {
  // Tet 0-1-2-3 of material 1 and tet 1-2-3-4 of material 2 in material 0: interfaces 0/1 and 0/2 end on the triple
  // curve 1-2-3 (0, 1, 2), where the single triangle of 1/2 lies.
  InterfaceMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  m.vertex_kind = {kInterface, kCurve, kCurve, kCurve, kInterface};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 4}, {1, 4, 3}, {2, 3, 4}, {1, 2, 3}};
  m.pair = {{0, 1}, {0, 1}, {0, 1}, {0, 2}, {0, 2}, {0, 2}, {1, 2}};
  m.face = {0, 1, 2, 3, 4, 5, 6};
  CHECK(nonmanifold_faces(m).empty());
  // With vertex 1 off the curve, the edges from it along the curve are open off the curves in all three interfaces.
  m.vertex_kind[1] = kInterface;
  CHECK(nonmanifold_faces(m) == std::vector<uint32_t>{0, 1, 3, 4, 6});
}

TEST_CASE("clustered junction points: one quadruple point per cluster, and no curve point inside its ball") {
  constexpr auto kPoint = uint8_t(fields::FeatureKind::quadruple_point);
  // h 1: quadruple points 0.0002 and 0.2 from point 0 (within kCrowding x h = 0.3) go, one 0.5 away stays; a curve
  // point 0.1 from point 0 goes, one 0.4 away and an interface point 0.05 away stay.
  const std::vector<glm::dvec3> points = {{0, 0, 0}, {0.0002, 0, 0}, {0, 0.2, 0}, {0.5, 0, 0},
                                          {0, 0, 0.1}, {0, 0, 0.4}, {0, 0.05, 0}};
  const std::vector<uint8_t> kind = {kPoint, kPoint, kPoint, kPoint, kCurve, kCurve, kInterface};
  const std::vector<float> h(points.size(), 1.0f);
  CHECK(clustered_junction_points(points, kind, h, 1.0) == std::vector<uint32_t>{1, 2, 4});
  // The ball is at most half a voxel: at h 10 the point 0.5 away stays, the curve point 0.4 away goes.
  CHECK(clustered_junction_points(points, kind, std::vector<float>(points.size(), 10.0f), 1.0) ==
        std::vector<uint32_t>{1, 2, 4, 5});
  // Nothing within the floor (a twentieth of a voxel) or the ball when h and the voxels are small.
  CHECK(clustered_junction_points(points, kind, std::vector<float>(points.size(), 0.0001f), 0.001).empty());
}
