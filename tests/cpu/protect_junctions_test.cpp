// particles::protect_junctions and particles::thin_crowded: interface particles within rho x h of a bounding triple
// curve or quadruple point are removed, others (and every curve particle) kept; crowded particles of one feature thinned.
#include <doctest/doctest.h>

#include <cmath>
#include <numbers>

#include "fields/fields_stage.h"
#include "fields_volumes.h"
#include "particles/population.h"

using namespace cpmesh;
using fields::FeatureKind;

namespace {

// The 64^3 wedge ball and its fields, built once for both tests.
struct WedgeBall {
  test::FieldsVolume volume = test::make_volume(io::SynthShape::wedge_ball, 64);
  fields::FieldsResult fields = fields::build_fields(volume.grid, volume.labels.data());
};

const WedgeBall& wedge_ball_64() {
  static const WedgeBall built;
  return built;
}

}  // namespace

TEST_CASE("protect_junctions: the band around the wedge ball's axis curve") {
  const auto& wb = wedge_ball_64().volume;
  const auto& F = wedge_ball_64().fields;
  const auto& E = F.embedding;
  // Materials are label indices here (labels 0..4). The 1|2 wedge plane is the half-plane at angle 0.3 + 120 deg
  // through the z axis; the axis itself is the (1,2,3) curve from the north pole down to the inner ball.
  const int plane = E.feature_index(FeatureKind::interface, {1, 2, 0xffff, 0xffff});
  const int axis = E.feature_index(FeatureKind::triple_curve, {1, 2, 3, 0xffff});
  const int other = E.feature_index(FeatureKind::interface, {0, 1, 0xffff, 0xffff});
  REQUIRE(plane >= 0);
  REQUIRE(axis >= 0);
  REQUIRE(other >= 0);
  const double R = 25.0, theta = 0.3 + 2 * std::numbers::pi / 3;
  const glm::dvec3 dir(std::cos(theta), std::sin(theta), 0.0);
  const float h = 2.0f;
  particles::Population P;
  auto add = [&](const glm::dvec3& p, int feature) {
    P.particles.push_back(glm::vec4(glm::vec3(p), h));
    P.features.push_back(uint32_t(feature));
  };
  // Curve particles along the axis, 2 voxels apart, from 0.45 R to 0.9 R above the centre.
  for (double z = 0.45 * R; z <= 0.9 * R; z += 2.0) add(wb.centre + glm::dvec3(0, 0, z), axis);
  const size_t curve_particles = P.particles.size();
  const glm::dvec3 at = wb.centre + glm::dvec3(0, 0, 0.7 * R + 1.0);  // between two curve particles
  add(at + 0.5 * dir, plane);   // 0.5 voxel from the axis: inside the band of 0.55 x 2
  add(at + 0.9 * dir, plane);   // 0.9: inside
  add(at + 1.5 * dir, plane);   // 1.5: outside
  add(at + 6.0 * dir, plane);   // far
  add(wb.centre + glm::dvec3(0, 0, R - 0.6) + 0.3 * dir, plane);  // 0.67 from the north pole (a quadruple point)
  // An interface the axis does not bound ((0,1): the outer sphere) is not protected by it: a particle there, put
  // next to the axis curve's particles for the test, stays.
  add(at + 0.5 * dir, other);
  const size_t removed = particles::protect_junctions(F.fields, E, P, 0.55);
  CHECK(removed == 3);
  REQUIRE(P.particles.size() == curve_particles + 3);
  for (size_t i = 0; i < curve_particles; ++i) CHECK(P.features[i] == uint32_t(axis));
  CHECK(glm::length(glm::dvec3(glm::vec3(P.particles[curve_particles])) - at) == doctest::Approx(1.5).epsilon(1e-5));
  CHECK(glm::length(glm::dvec3(glm::vec3(P.particles[curve_particles + 1])) - at) == doctest::Approx(6.0).epsilon(1e-5));
  CHECK(P.features[curve_particles + 2] == uint32_t(other));
  // rho = 0: nothing is removed.
  CHECK(particles::protect_junctions(F.fields, E, P, 0.0) == 0);
}

TEST_CASE("drop_off_feature: particles off their feature go, those on it stay in order, quadruple points always stay") {
  const auto& wb = wedge_ball_64().volume;
  const auto& F = wedge_ball_64().fields;
  const auto& E = F.embedding;
  const int plane = E.feature_index(FeatureKind::interface, {1, 2, 0xffff, 0xffff});
  const int axis = E.feature_index(FeatureKind::triple_curve, {1, 2, 3, 0xffff});
  REQUIRE(plane >= 0);
  REQUIRE(axis >= 0);
  REQUIRE(!E.quadruple_points.empty());
  // The 1|2 wedge plane (as in the test above) and its normal.
  const double R = 25.0, theta = 0.3 + 2 * std::numbers::pi / 3;
  const glm::dvec3 dir(std::cos(theta), std::sin(theta), 0.0), normal(-std::sin(theta), std::cos(theta), 0.0);
  const float h = 2.0f;
  auto on = [&](int feature, const glm::dvec3& near) {
    glm::dvec3 foot;
    REQUIRE(fields::project_to_feature(F.fields, E.features[size_t(feature)], near, foot));
    return foot;
  };
  const glm::dvec3 p = on(plane, wb.centre + glm::dvec3(0, 0, 0.3 * R) + 0.5 * R * dir);
  const glm::dvec3 c = on(axis, wb.centre + glm::dvec3(0, 0, 0.7 * R));
  // To first order the distance across the plane, in voxels (unit spacing).
  CHECK(fields::feature_distance(F.fields, E.features[size_t(plane)], p) < 0.01);
  CHECK(fields::feature_distance(F.fields, E.features[size_t(plane)], p + 1.0 * normal) ==
        doctest::Approx(1.0).epsilon(0.15));
  CHECK(std::isinf(fields::feature_distance(F.fields, E.features[size_t(plane)], wb.centre + glm::dvec3(0, 0, 1.3 * R))));
  particles::Population P;
  auto add = [&](const glm::dvec3& x, int feature) {
    P.particles.push_back(glm::vec4(glm::vec3(x), h));
    P.features.push_back(uint32_t(feature));
  };
  add(p, plane);                                       // kept
  add(p + 0.3 * normal, plane);                        // 0.3 voxel = 0.15 h off: kept at a share of 0.25
  add(p + 1.0 * normal, plane);                        // 0.5 h: removed
  add(wb.centre + glm::dvec3(0, 0, 1.3 * R), plane);   // outside the ball, both fields clamped (no gradient): removed
  // On the 1|2 plane's level set f1 = f2 continued into the inner ball (material 4), 2 voxels inside it: the
  // constraint holds, but material 4's field is above both. Removed.
  const glm::dvec3 inner = wb.centre + glm::dvec3(3.0, 2.0, 2.5);  // the 64^3 ball's inner centre (radius 9)
  const glm::dvec3 across = inner - glm::dot(inner - wb.centre, normal) * normal;  // on the plane
  const glm::dvec3 q = on(plane, across + glm::dvec3(0, 0, std::sqrt(49.0 - glm::dot(inner - across, inner - across))));
  CHECK(glm::length(q - inner) < 8.0);
  double f[5];
  for (int m = 0; m < 5; ++m) f[m] = F.fields.fields[size_t(m)].sample_cubic(q / F.fields.grid.spacing);
  CHECK(f[4] > std::max(f[1], f[2]) + 1.0);
  CHECK(fields::feature_distance(F.fields, E.features[size_t(plane)], q) == doctest::Approx(f[4] - std::min(f[1], f[2])));
  add(q, plane);
  add(c, axis);                                        // kept
  add(c + 1.5 * dir, axis);                            // off the curve, on its 1|2 plane: removed
  add(E.quadruple_points[0].position + glm::dvec3(3.0, 0, 0), int(E.quadruple_points[0].feature));  // kept
  const particles::Population before = P;
  CHECK(particles::drop_off_feature(F.fields, E, P, 0.25) == 4);
  REQUIRE(P.particles.size() == 4);
  for (auto [kept, was] : {std::pair{0, 0}, {1, 1}, {2, 5}, {3, 7}}) {
    CAPTURE(kept);
    CHECK(P.particles[size_t(kept)] == before.particles[size_t(was)]);
    CHECK(P.features[size_t(kept)] == before.features[size_t(was)]);
  }
  // A share of 0: only a particle exactly on its feature would stay; these are within 0.01 voxel, not exactly on.
  particles::Population strict = before;
  CHECK(particles::drop_off_feature(F.fields, E, strict, 0.0) >= 6);
}

TEST_CASE("thin_crowded: of particles of one feature closer than share x h, the first stays") {
  const auto& E = wedge_ball_64().fields.embedding;
  const int plane = E.feature_index(FeatureKind::interface, {1, 2, 0xffff, 0xffff});
  const int axis = E.feature_index(FeatureKind::triple_curve, {1, 2, 3, 0xffff});
  REQUIRE(plane >= 0);
  REQUIRE(axis >= 0);
  const float h = 2.0f;  // share 0.5: closer than 1 voxel is crowded
  particles::Population P;
  auto add = [&](float x, int feature) {
    P.particles.push_back(glm::vec4(20.0f + x, 30.0f, 30.0f, h));
    P.features.push_back(uint32_t(feature));
  };
  add(0.0f, plane);  // kept: the first
  add(0.5f, plane);  // 0.5 from the first: left out
  add(0.1f, axis);   // as close, but another feature: kept
  add(1.5f, plane);  // 1.5 from the first (the one left out does not count): kept
  add(2.2f, plane);  // 0.7 from the one before: left out
  add(3.4f, plane);  // 1.2 from the nearest kept: kept
  CHECK(particles::thin_crowded(E, P, 0.5) == 2);
  REQUIRE(P.particles.size() == 4);
  CHECK(P.particles[0].x == doctest::Approx(20.0));
  CHECK(P.features[1] == uint32_t(axis));
  CHECK(P.particles[2].x == doctest::Approx(21.5));
  CHECK(P.particles[3].x == doctest::Approx(23.4));
  CHECK(particles::thin_crowded(E, P, 0.0) == 0);
}
