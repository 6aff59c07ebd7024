// Triple-curve edges of interface meshes (mesh::triple_curve_edges) and the analytic curve distance
// (io::distance_to_triple_curve): the measures behind the junction error of the tests and benchmarks.
#include <doctest/doctest.h>

#include <cmath>

#include "io/synth_volumes.h"
#include "mesh/quality.h"

using namespace cpmesh;

TEST_CASE("triple_curve_edges: the edge three interfaces share, and no other") {
  // Edge 0-1 is shared by three triangles of pairs (1,2), (2,3), (1,3): a triple-curve edge of materials 1, 2, 3.
  // Edge 0-2 is shared by two pairs only; edge 1-5 by three pairs spanning four materials (not one curve).
  const std::vector<std::array<uint32_t, 3>> T = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}, {0, 2, 6}, {1, 5, 2}, {5, 1, 6}, {1, 5, 7}};
  const std::vector<std::array<uint16_t, 2>> P = {{1, 2}, {3, 2}, {1, 3}, {2, 3}, {1, 2}, {3, 4}, {2, 4}};
  const auto edges = mesh::triple_curve_edges(T, P);
  REQUIRE(edges.size() == 1);
  CHECK(edges[0].a == 0);
  CHECK(edges[0].b == 1);
  CHECK(edges[0].materials == std::array<uint16_t, 3>{1, 2, 3});
}

TEST_CASE("distance_to_triple_curve: wedge ball curves, and none for other material sets") {
  io::SynthOptions o;
  o.shape = io::SynthShape::wedge_ball;
  o.size = 64;
  const auto s = io::make_synth_volume(o);
  // The first quadruple point (north pole) lies on the (0, l, r) curves and on the axis curve (1, 2, 3).
  const auto& north = s.junctions.quadruple_points[0].position;
  CHECK(io::distance_to_triple_curve(s.junctions, {1, 2, 3}, north) < 1e-9);
  CHECK(io::distance_to_triple_curve(s.junctions, {0, 1, 2}, north) < 1e-9);
  // One voxel off the pole along x: at most 1 from each curve through it.
  const std::array<double, 3> off = {north[0] + 1, north[1], north[2]};
  const double d = io::distance_to_triple_curve(s.junctions, {1, 2, 3}, off);
  CHECK(d == doctest::Approx(1.0).epsilon(1e-9));  // the axis curve is parallel to z
  CHECK(std::isinf(io::distance_to_triple_curve(s.junctions, {0, 1, 4}, north)));
}
