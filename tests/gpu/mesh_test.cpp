// The whole pipeline (mesh::mesh_volume, issue 8) on the analytic volumes: Delaunay, restricted-Delaunay labels,
// repair, interface extraction, the quality report and the constrained volume mesh.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include "fields_volumes.h"
#include "gpu_fixture.h"
#include "io/synth_volumes.h"
#include "mesh/pipeline.h"
#include "mesh/quality.h"
#include "render/preview.h"

using namespace cpmesh;
using cpmesh::test::GpuFixture;

namespace {

io::LabelVolume synth(io::SynthShape shape, int size, double radius, glm::dvec3* centre = nullptr) {
  io::SynthOptions o;
  o.shape = shape;
  o.size = size;
  o.radius = radius;
  auto s = io::make_synth_volume(o);
  if (centre) *centre = glm::dvec3(s.centre[0], s.centre[1], s.centre[2]);
  return s.volume;
}

glm::dvec3 vec(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

// Distance from p to triangle abc (Ericson, Real-Time Collision Detection 5.1.5).
double point_triangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const glm::dvec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return glm::length(p - a);
  const glm::dvec3 bp = p - b;
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return glm::length(p - b);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return glm::length(p - (a + d1 / (d1 - d3) * ab));
  const glm::dvec3 cp = p - c;
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return glm::length(p - c);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return glm::length(p - (a + d2 / (d2 - d6) * ac));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return glm::length(p - (b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b)));
  const double denom = 1 / (va + vb + vc);
  return glm::length(p - (a + ab * (vb * denom) + ac * (vc * denom)));
}

// Junction error (mesh/quality.h) of the edges on triple curves whose both ends are curve or quadruple-point
// vertices, in voxels (the synthetic volumes' spacing is 1).
mesh::JunctionError curve_edge_error(const io::TriangleMesh& s, const io::Junctions& junctions) {
  std::vector<uint8_t> on_curve(s.vertices.size());
  for (size_t v = 0; v < on_curve.size(); ++v)
    on_curve[v] = s.vertex_feature[v] != uint8_t(io::VertexFeature::interface);
  return mesh::junction_error(junctions, s.vertices, s.triangles, s.triangle_pair, 1.0, &on_curve);
}

}  // namespace

TEST_CASE("radius ratio, dihedral angles and radius-edge ratio on known shapes") {
  const glm::dvec3 a(0, 0, 0), b(1, 0, 0), c(0.5, std::sqrt(3.0) / 2, 0);
  CHECK(mesh::radius_ratio(a, b, c) == doctest::Approx(1.0));
  CHECK(mesh::radius_ratio(a, b, glm::dvec3(0.5, 0.01, 0)) < 0.05);
  const glm::dvec3 d(0.5, std::sqrt(3.0) / 6, std::sqrt(2.0 / 3.0));  // regular tet
  for (double angle : mesh::dihedral_angles(a, b, c, d)) CHECK(angle * 180 / M_PI == doctest::Approx(70.5288).epsilon(1e-4));
  CHECK(mesh::radius_edge_ratio(a, b, c, d) == doctest::Approx(std::sqrt(6.0) / 4).epsilon(1e-9));
  // A closed tetrahedron surface has no odd edge; one face less leaves three.
  const std::vector<std::array<uint32_t, 3>> tet = {{0, 1, 2}, {0, 3, 1}, {1, 3, 2}, {0, 2, 3}};
  CHECK(mesh::odd_edges(tet) == 0);
  CHECK(mesh::odd_edges({tet[0], tet[1], tet[2]}) == 3);
  const auto check = mesh::check_surface({tet[0], tet[1], tet[2]}, {0, 0, 0, 0});
  CHECK(check.boundary_edges == 3);
  CHECK(check.open_edges == 3);
  CHECK(mesh::check_surface({tet[0], tet[1], tet[2]}, {1, 1, 1, 1}).open_edges == 0);
}

TEST_CASE_FIXTURE(GpuFixture, "sphere: interface within 0.5 voxel of the analytic sphere both ways, closed, quality tets") {
  glm::dvec3 centre;
  const double R = 12;
  const auto volume = synth(io::SynthShape::sphere, 36, R, &centre);
  mesh::MeshOptions options;
  options.fields.sizing.h_max = 2.0;
  std::vector<mesh::StageEvent> events;
  const auto r = mesh::mesh_volume(ctx, volume, options, [&](const mesh::StageEvent& e) { events.push_back(e); });
  // Progress: every stage starts, ends with its time and what it made, in the report's order; the advection reports
  // its rounds while it runs.
  const auto& seconds = r.report.seconds;
  REQUIRE(seconds.size() == 7);
  size_t updates = 0, ends = 0;
  for (size_t i = 0; i < events.size(); ++i) {
    const auto& e = events[i];
    CHECK(e.count == 7);
    REQUIRE(e.index >= 1);
    REQUIRE(e.index <= 7);
    CHECK(e.stage == seconds[size_t(e.index - 1)].first);
    if (e.seconds >= 0) {
      CHECK(e.seconds == seconds[size_t(e.index - 1)].second);
      CHECK(!e.detail.empty());
      CHECK(size_t(e.index) == ++ends);
    } else if (!e.detail.empty() && e.stage == "advection") {
      CHECK(e.detail.find("particles") != std::string::npos);
      ++updates;
    } else if (!e.detail.empty()) {
      CHECK(e.stage == "delaunay and extraction");
      CHECK(e.detail.find("refinement round") != std::string::npos);
    } else {
      CHECK(size_t(e.index) == ends + 1);  // a stage starts after the one before it ended
    }
  }
  CHECK(ends == 7);
  // The steps of "fields", "delaunay and extraction" and "volume mesh", in order, each within its stage.
  const std::vector<std::pair<std::string, std::string>> steps = {{"fields", "indicator fields"},
                                                                   {"fields", "embedding"},
                                                                   {"fields", "sizing field"},
                                                                   {"delaunay and extraction", "tetrahedralization"},
                                                                   {"delaunay and extraction", "extraction"},
                                                                   {"volume mesh", "region seeds"},
                                                                   {"volume mesh", "cutting into pieces"},
                                                                   {"volume mesh", "TetGen runs"},
                                                                   {"volume mesh", "merge and seams"},
                                                                   {"volume mesh", "interface vertex moves"},
                                                                   {"volume mesh", "output and statistics"}};
  REQUIRE(r.report.steps.size() == steps.size());
  std::map<std::string, double> within;
  for (size_t i = 0; i < steps.size(); ++i) {
    CHECK(r.report.steps[i].stage == steps[i].first);
    CHECK(r.report.steps[i].step == steps[i].second);
    CHECK(r.report.steps[i].seconds >= 0);
    within[r.report.steps[i].stage] += r.report.steps[i].seconds;
  }
  for (const auto& [stage, s] : seconds)
    if (within.count(stage)) {
      CHECK(within[stage] > 0);
      CHECK(within[stage] <= s);
    }
  CHECK(updates == r.report.rounds);
  CHECK(events.back().detail.find(" tets") != std::string::npos);
  const auto& S = r.surfaces;
  REQUIRE(S.triangles.size() > 200);
  // Mesh -> sphere: vertices and triangle centroids.
  double to_sphere = 0;
  for (const auto& t : S.triangles) {
    const glm::dvec3 p[3] = {vec(S.vertices[t[0]]), vec(S.vertices[t[1]]), vec(S.vertices[t[2]])};
    for (const auto& q : {p[0], p[1], p[2], (p[0] + p[1] + p[2]) / 3.0}) to_sphere = std::max(to_sphere, std::fabs(glm::length(q - centre) - R));
  }
  // Sphere -> mesh: random points of the sphere.
  std::mt19937 rng(2);
  std::normal_distribution<double> n01;
  double to_mesh = 0;
  for (int k = 0; k < 400; ++k) {
    const glm::dvec3 q = centre + R * glm::normalize(glm::dvec3(n01(rng), n01(rng), n01(rng)));
    double best = 1e30;
    for (const auto& t : S.triangles) best = std::min(best, point_triangle(q, vec(S.vertices[t[0]]), vec(S.vertices[t[1]]), vec(S.vertices[t[2]])));
    to_mesh = std::max(to_mesh, best);
  }
  const auto& rep = r.report;
  MESSAGE("Hausdorff: mesh to sphere " << to_sphere << ", sphere to mesh " << to_mesh << " voxel; " << S.triangles.size()
                                       << " triangles, radius ratio mean " << rep.surface.mean_radius_ratio << " min "
                                       << rep.surface.min_radius_ratio << "; volume mesh " << rep.volume.tets
                                       << " tets, dihedral " << rep.volume.min_dihedral_deg << ".."
                                       << rep.volume.max_dihedral_deg);
  CHECK(to_sphere < 0.5);
  CHECK(to_mesh < 0.5);
  REQUIRE(rep.interfaces.size() == 1);
  CHECK(rep.interfaces[0].check.manifold());
  CHECK(rep.interfaces[0].check.boundary_edges == 0);
  CHECK(rep.materials_closed == 2);
  CHECK(rep.surface.mean_radius_ratio > 0.85);
  CHECK(rep.volume_error.empty());
  CHECK(rep.volume.tets > 0);
  CHECK(std::set<uint16_t>(r.volume.tet_material.begin(), r.volume.tet_material.end()) == std::set<uint16_t>{1});
  // Every node of the volume mesh is in a tet (particles left out of the interfaces are not written as nodes).
  std::vector<uint8_t> in_tet(r.volume.vertices.size(), 0);
  for (const auto& t : r.volume.tets)
    for (uint32_t v : t) in_tet.at(v) = 1;
  CHECK(std::count(in_tet.begin(), in_tet.end(), 0) == 0);
  CHECK(rep.crossing_triangles == 0);
}

TEST_CASE_FIXTURE(GpuFixture, "more particles than max_particles: stops after seeding with the count") {
  const auto volume = synth(io::SynthShape::sphere, 36, 12, nullptr);
  mesh::MeshOptions options;
  options.max_particles = 50;
  std::vector<std::string> ended;
  try {
    mesh::mesh_volume(ctx, volume, options, [&](const mesh::StageEvent& e) {
      if (e.seconds >= 0) ended.push_back(e.stage);
    });
    FAIL("no error");
  } catch (const mesh::ParticleBudgetError& e) {
    const std::string what = e.what();
    CHECK(what.find("more than the limit of 50") != std::string::npos);
    CHECK(what.find("--min-size") != std::string::npos);
  }
  CHECK(ended == std::vector<std::string>{"fields"});  // no advection started
}

TEST_CASE_FIXTURE(GpuFixture, "wedge ball end to end: every material closed, interfaces share curve vertices") {
  io::SynthOptions so;
  so.shape = io::SynthShape::wedge_ball;
  so.size = 40;
  const auto wb = io::make_synth_volume(so);
  const auto& volume = wb.volume;
  const auto r = mesh::mesh_volume(ctx, volume);
  const auto& rep = r.report;
  MESSAGE(rep.particles << " particles, " << rep.surface.triangles << " triangles, radius ratio mean "
                        << rep.surface.mean_radius_ratio << " min " << rep.surface.min_radius_ratio << "; wrong faces "
                        << rep.wrong_faces_before_repair << " -> " << rep.wrong_faces << " (" << rep.relabelled_tets
                        << " tets relabelled, " << rep.refinement_points << " refinement points); "
                        << rep.interfaces_manifold << " of " << rep.interfaces.size() << " interfaces manifold; volume "
                        << rep.volume.tets << " tets, dihedral " << rep.volume.min_dihedral_deg << ".."
                        << rep.volume.max_dihedral_deg);
  CHECK(rep.interfaces.size() == 9);
  CHECK(rep.materials_closed == rep.materials.size());
  // With the junction protection every interface is an oriented 2-manifold bounded by triple curves and no triangle
  // degenerates; the smoothing lifts the mean (measured: 9 of 9, no wrong face left, radius ratio mean 0.957,
  // min 0.67; the triangles with a curve or quadruple-point vertex 0.944, 0.933 with the area-weighted centroid as
  // the interface vertices' target and curve vertices at their neighbours' midpoint, smooth.h).
  for (const auto& ir : rep.interfaces) CHECK(ir.check.manifold());
  CHECK(rep.protected_particles > 0);
  CHECK(rep.wrong_faces == 0);
  CHECK(rep.smoothing_moves > 0);
  CHECK(rep.surface.min_radius_ratio > 0.3);
  CHECK(rep.surface.mean_radius_ratio > 0.92);
  CHECK(rep.junction_triangles.mean_radius_ratio > 0.94);
  // The sliver passes never make the volume mesh worse than TetGen left it, and reach the 10 degrees: the
  // worst tets TetGen leaves have four interface vertices (two kept triangles folded by a few degrees), which
  // split_slivers refills around a new vertex where the vertex moves cannot help (its own test is in the cpu suite;
  // measured 12.0-12.4 degrees at 40^3, 48^3, 64^3 and 128^3).
  CHECK(rep.volume.min_dihedral_deg >= rep.tet_improvement.min_dihedral_before);
  CHECK(rep.sliver_split.failed == 0);
  CHECK(rep.volume.min_dihedral_deg >= 10);
  // Conforming: triangles of different interfaces meet at curve or quadruple-point vertices.
  std::vector<std::set<std::array<uint16_t, 2>>> pairs_at(r.surfaces.vertices.size());
  for (size_t i = 0; i < r.surfaces.triangles.size(); ++i)
    for (uint32_t v : r.surfaces.triangles[i]) pairs_at[v].insert(r.surfaces.triangle_pair[i]);
  size_t shared = 0;
  for (size_t v = 0; v < pairs_at.size(); ++v)
    if (pairs_at[v].size() >= 2 && r.surfaces.vertex_feature[v] != uint8_t(io::VertexFeature::interface)) ++shared;
  CHECK(shared > 50);
  const auto ce = curve_edge_error(r.surfaces, wb.junctions);  // the grid's spacing is 1: voxels
  MESSAGE(ce.edges << " triple-curve edges: midpoint distance to the analytic curves mean " << ce.mean << ", max "
                   << ce.max << " voxel; whole edges (ends included) max " << ce.max_whole_edge);
  CHECK(ce.edges > 30);
  CHECK(ce.spurious == 0);
  // Measured at 40^3: mean 0.15, max 0.555 (the bundled 48^3 volume: the next test; 0.545 when the curves' fine points
  // took the nearer-projection retry only where the linearized distance asked for it). Without the T-junction
  // extrapolation (closest_point_embedding.h): mean 0.23, max 0.56; before, without the junction correction: mean
  // 0.30, max 0.66.
  CHECK(ce.mean < 0.2);
  CHECK(ce.max < 0.57);
  CHECK(ce.max_whole_edge < 0.8);  // measured 0.70: the south pole's quadruple point, which the 40^3 data puts anywhere in a voxel
  CHECK(rep.volume_error.empty());
  CHECK(std::set<uint16_t>(r.volume.tet_material.begin(), r.volume.tet_material.end()) == std::set<uint16_t>{1, 2, 3, 4});
  // The materials are meshed apart (volume_mesh.h) and must conform: every interface triangle is a face of exactly one
  // tet of each meshed material beside it (the outside, label 0, has none), and no other tet face lies on it.
  {
    std::map<std::array<uint32_t, 3>, std::multiset<uint16_t>> on_face;
    for (const auto& tri : r.volume.triangles) {
      auto f = tri;
      std::sort(f.begin(), f.end());
      on_face[f];
    }
    for (size_t i = 0; i < r.volume.tets.size(); ++i)
      for (int c = 0; c < 4; ++c) {
        const auto& t = r.volume.tets[i];
        std::array<uint32_t, 3> f = {t[size_t((c + 1) % 4)], t[size_t((c + 2) % 4)], t[size_t((c + 3) % 4)]};
        std::sort(f.begin(), f.end());
        const auto it = on_face.find(f);
        if (it != on_face.end()) it->second.insert(r.volume.tet_material[i]);
      }
    size_t wrong = 0;
    for (size_t i = 0; i < r.volume.triangles.size(); ++i) {
      auto f = r.volume.triangles[i];
      std::sort(f.begin(), f.end());
      std::multiset<uint16_t> expect;
      for (uint16_t l : r.volume.triangle_pair[i])
        if (l != 0) expect.insert(l);
      wrong += on_face[f] != expect;
    }
    CHECK(wrong == 0);
  }

  // The preview shows the ball in both halves, in several pair colours.
  const auto scene = render::preview_scene(r.surfaces, 400, 200);
  const auto image = render::rasterize(ctx, scene);
  size_t covered[2] = {0, 0};
  std::set<uint32_t> colours;
  for (uint32_t y = 0; y < image.height; ++y)
    for (uint32_t x = 0; x < image.width; ++x) {
      const uint32_t p = image.rgba[size_t(y) * image.width + x];
      if (p == scene.background) continue;
      ++covered[x >= image.width / 2];
      colours.insert(p);
    }
  const double half = 200.0 * 200.0;
  MESSAGE("preview: " << covered[0] / half << " and " << covered[1] / half << " of each half covered, "
                      << colours.size() << " colours");
  CHECK(covered[0] / half > 0.3);  // a ball filling 92% of the view's height covers about 0.6 of it
  CHECK(covered[0] / half < 0.8);
  CHECK(covered[1] / half > 0.2);
  CHECK(colours.size() > 50);
}

TEST_CASE_FIXTURE(GpuFixture, "bundled wedge ball (48^3): triple-curve edges within 0.5 voxel of the analytic curves, ends included") {
  // Issue 8's criterion on the README's demo volume (assets/wedge_ball_48.nrrd is this synthetic volume).
  io::SynthOptions so;
  so.shape = io::SynthShape::wedge_ball;
  so.size = 48;
  const auto wb = io::make_synth_volume(so);
  mesh::MeshOptions options;
  options.only_surfaces = true;
  const auto r = mesh::mesh_volume(ctx, wb.volume, options);
  const auto ce = curve_edge_error(r.surfaces, wb.junctions);
  MESSAGE(r.report.particles << " particles; " << ce.edges << " triple-curve edges: midpoints mean " << ce.mean
                             << ", max " << ce.max << " voxel; whole edges max " << ce.max_whole_edge);
  CHECK(ce.edges > 50);
  CHECK(ce.spurious == 0);
  // Measured (seeds 1-3, only this seed here): whole edges 0.42-0.46, midpoints 0.30-0.35 at most, mean 0.11-0.12.
  // Before the inner-ball curves passed as T-junctions (tangent test, closest_point_embedding.cpp) and the sizing
  // field's chord bound: whole edges 0.53-0.54, on the inner ball's curves.
  CHECK(ce.mean < 0.15);
  CHECK(ce.max < 0.45);
  CHECK(ce.max_whole_edge < 0.5);
  CHECK(r.report.interfaces_manifold == r.report.interfaces.size());
  CHECK(r.report.surface.mean_radius_ratio >= 0.93);
}

TEST_CASE_FIXTURE(GpuFixture, "wedge ball at other seeds: every run manifold and closed with tets over 10 degrees") {
  // The meshes must not depend on luck: the 40^3 wedge ball once lost its tet mesh with seed 4 (before the curve
  // smoothing; with it, seed 1 did: a hull face sampled its outside inside a material), and the bundled 48^3 one had
  // a 9.2-degree sliver that only edge removal fixes. Seed 1 is the test above.
  const auto volume = synth(io::SynthShape::wedge_ball, 40, 0);
  for (uint32_t seed : {2u, 3u, 4u}) {
    CAPTURE(seed);
    mesh::MeshOptions options;
    options.population.seed = seed;
    const auto r = mesh::mesh_volume(ctx, volume, options);
    const auto& rep = r.report;
    MESSAGE("seed " << seed << ": " << rep.particles << " particles, " << rep.interfaces_manifold << " of "
                    << rep.interfaces.size() << " interfaces manifold, " << rep.materials_closed << " of "
                    << rep.materials.size() << " materials closed, radius ratio " << rep.surface.mean_radius_ratio
                    << " / " << rep.surface.min_radius_ratio << ", dihedral " << rep.volume.min_dihedral_deg);
    CHECK(rep.interfaces_manifold == rep.interfaces.size());
    CHECK(rep.materials_closed == rep.materials.size());
    CHECK(rep.wrong_faces == 0);
    CHECK(rep.volume_error.empty());
    CHECK(rep.volume.min_dihedral_deg >= 10);
    CHECK(rep.surface.min_radius_ratio > 0.2);
    CHECK(rep.surface.mean_radius_ratio >= 0.93);
  }
}

TEST_CASE_FIXTURE(GpuFixture, "the repair inserts curve points into the Delaunay mesh where triangles span a curve") {
  // With junction protection off, interface particles creep up to the wedge ball's curves and triangles span them
  // (measured at 40^3: 120 wrong faces, 5 curve points added): the surfaces come from a mesh with insertions
  // (DelaunayMesh::insert), every added point a vertex of them.
  const auto volume = synth(io::SynthShape::wedge_ball, 40, 0);
  mesh::MeshOptions options;
  options.junction_protection = 0;
  options.only_surfaces = true;
  options.collapses.passes = 0;  // which would remove some of those vertices again where they crowd a neighbour
  const auto r = mesh::mesh_volume(ctx, volume, options);
  const auto& rep = r.report;
  MESSAGE(rep.wrong_faces_before_repair << " wrong faces, " << rep.refinement_points << " refinement points, "
                                        << rep.wrong_faces << " left");
  CHECK(rep.refinement_points > 0);
  CHECK(rep.wrong_faces < rep.wrong_faces_before_repair);
  REQUIRE(r.surfaces.vertices.size() == rep.particles + rep.refinement_points - rep.refinement_removals);
  std::vector<uint8_t> used(r.surfaces.vertices.size(), 0);
  for (const auto& t : r.surfaces.triangles)
    for (uint32_t v : t) used[v] = 1;
  for (size_t v = rep.particles; v < used.size(); ++v) CHECK(used[v]);
}

TEST_CASE_FIXTURE(GpuFixture, "concentric shells with 1- and 1.5-voxel layers: crossing-free interfaces and a volume mesh") {
  // Layers thinner than the triangles are wide: the interface smoothing once pushed triangles of one side through
  // the other's, and TetGen refused the surfaces ("a segment and a subface intersect"). The thin layers' own mesh
  // quality is not asserted here: their interfaces follow the one-voxel staircase (docs/benchmarks.md, "The wedge
  // ball, thin layers and the 128³ comparison").
  const auto volume = synth(io::SynthShape::shells, 32, 0);
  const auto r = mesh::mesh_volume(ctx, volume);
  const auto& rep = r.report;
  MESSAGE(rep.particles << " particles, radius ratio " << rep.surface.mean_radius_ratio << " / "
                        << rep.surface.min_radius_ratio << ", " << rep.smoothing_moves << " smoothing moves, "
                        << rep.volume.tets << " tets, " << rep.refinement_points << " refinement points"
                        << (rep.volume_error.empty() ? "" : ": " + rep.volume_error));
  CHECK(rep.smoothing_moves > 0);
  // The thin layers' fields make particles that lie off their features (measured: 752 of 29.6k); left out, they take
  // every wrong face with them (before: 285 wrong faces, 134 left after the repair's 3 curve points).
  CHECK(rep.off_feature_particles > 0);
  CHECK(rep.wrong_faces == 0);
  CHECK(rep.crossing_triangles == 0);
  CHECK(rep.materials_closed == rep.materials.size());
  CHECK(rep.volume_error.empty());
  CHECK(std::set<uint16_t>(r.volume.tet_material.begin(), r.volume.tet_material.end()) ==
        std::set<uint16_t>{1, 2, 3, 4, 5});
}

TEST_CASE("materials: keep, merge and drop labels; a missing label is named") {
  io::LabelVolume v;
  v.dims = {4, 1, 1};
  v.labels = {0, 1, 2, 3};
  v.source = "v.nrrd";
  const auto merged = mesh::select_materials(v, {{1, 2}});
  CHECK(merged.labels == std::vector<uint16_t>{0, 1, 1, 0});
  const auto kept = mesh::select_materials(v, {{3}, {2}});
  CHECK(kept.labels == std::vector<uint16_t>{0, 0, 2, 3});
  CHECK(mesh::select_materials(v, {}).labels == v.labels);
  try {
    mesh::select_materials(v, {{1, 7}});
    FAIL("label 7 accepted");
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    CHECK(what.find("v.nrrd") != std::string::npos);
    CHECK(what.find("label 7") != std::string::npos);
    CHECK(what.find("0,1,2,3") != std::string::npos);
  }
}

TEST_CASE("close_at_faces: label 0 outside the volume; padding only where another label lies on a face") {
  io::LabelVolume v;
  v.dims = {3, 2, 2};
  v.spacing = {1, 2, 0.5};
  v.origin = {10, 20, 30};
  v.labels.assign(12, 0);
  CHECK(fields::close_at_faces(v, 3).dims == v.dims);  // all 0: nothing to close
  v.labels[v.index(2, 1, 1)] = 7;
  const auto p = fields::close_at_faces(v, 3);
  // 3 voxels of the smallest spacing (0.5): 1.5 physical, so 2 voxels along x, 1 along y, 3 along z.
  CHECK(p.dims == std::array<int64_t, 3>{3 + 4, 2 + 2, 2 + 6});
  CHECK(p.origin == std::array<double, 3>{8, 18, 28.5});
  CHECK(p.spacing == v.spacing);
  CHECK(std::count(p.labels.begin(), p.labels.end(), uint16_t(7)) == 1);
  CHECK(p.labels[p.index(2 + 2, 1 + 1, 1 + 3)] == 7);
  CHECK(p.position(2 + 2, 1 + 1, 1 + 3) == v.position(2, 1, 1));  // physical positions stay
}

TEST_CASE_FIXTURE(GpuFixture, "a ball cut by the volume's bottom face is closed there by a flat cap (outside is label 0)") {
  // Ball of radius 9 centred 3 voxels above the bottom voxel centres: the face (z = -0.5) cuts it in a disk.
  const int n = 28;
  const glm::dvec3 c(13.6, 13.3, 3.0);
  const double R = 9;
  const io::LabelVolume v =
      test::label_volume(n, n, n, [&](int i, int j, int k) { return glm::length(glm::dvec3(i, j, k) - c) < R ? 1 : 0; });
  const auto r = mesh::mesh_volume(ctx, v);
  const auto& rep = r.report;
  CHECK(rep.face_padding[2] > 0);
  CHECK(rep.interfaces_manifold == 1);
  CHECK(rep.materials_closed == 2);
  CHECK(rep.crossing_triangles == 0);
  CHECK(rep.volume.tets > 0);
  CHECK(rep.volume_error.empty());
  CHECK(rep.surface.mean_radius_ratio > 0.9);
  // Distance of every vertex to the cut ball's boundary: the sphere above the face, the disk on it.
  const double rim = std::sqrt(R * R - (c.z + 0.5) * (c.z + 0.5));
  double worst = 0, worst_away = 0;
  size_t on_cap = 0;
  for (const auto& a : r.surfaces.vertices) {
    const glm::dvec3 p = vec(a);
    const double radial = std::hypot(p.x - c.x, p.y - c.y);
    const double d_sphere = p.z >= -0.5 ? std::abs(glm::length(p - c) - R) : 1e9;
    const double d_disk = radial <= rim ? std::abs(p.z + 0.5) : std::hypot(radial - rim, p.z + 0.5);
    const double d = std::min(d_sphere, d_disk);
    worst = std::max(worst, d);
    if (std::hypot(radial - rim, p.z + 0.5) > 2.5) worst_away = std::max(worst_away, d);
    on_cap += radial < rim - 2.5 && std::abs(p.z + 0.5) < 0.5;
  }
  MESSAGE("cut ball: worst ", worst, ", away from the rim ", worst_away, ", cap vertices ", on_cap);
  CHECK(worst_away < 0.5);
  CHECK(worst < 0.6);  // measured 0.35: the rim is rounded by less than a voxel
  CHECK(on_cap > 5);  // the cap is a surface, not a hole (measured 11)
}
