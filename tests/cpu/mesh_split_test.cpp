// Cutting a material into pieces for parallel TetGen runs (split_material.h) and the volume mesh made of the pieces
// (volume_mesh.h): the pieces are closed, fill the material exactly, share their separators and conform to the
// interfaces as the whole-material runs do.
#include <doctest/doctest.h>

#include <cmath>
#include <map>
#include <random>
#include <set>

#include "mesh/quality.h"
#include "mesh/split_material.h"
#include "mesh/volume_mesh.h"
#include "icosphere.h"

using namespace cpmesh;
using test::enclosed_volume;
using test::icosphere;
using test::Sphere;
using test::tet_volume;

namespace {

// Two nested spheres as interfaces: the outer one between materials 0 and 1, the inner one between 1 and 2.
struct Nested {
  std::vector<glm::dvec3> points;
  std::vector<std::array<uint32_t, 3>> triangles;
  std::vector<std::array<uint16_t, 2>> pair;
};
Nested nested(const Sphere& outer, const Sphere& inner) {
  Nested n{outer.points, outer.triangles, std::vector<std::array<uint16_t, 2>>(outer.triangles.size(), {0, 1})};
  const auto base = uint32_t(n.points.size());
  n.points.insert(n.points.end(), inner.points.begin(), inner.points.end());
  for (auto t : inner.triangles) {
    for (auto& v : t) v += base;
    n.triangles.push_back(t);
    n.pair.push_back({1, 2});
  }
  return n;
}

// The tets of material 1 (region 2) fill the shell between the spheres, those of material 2 (region 3) the inner ball.
void check_nested_volumes(std::map<int, double>& volume, const Sphere& outer, const Sphere& inner) {
  CHECK(volume.size() == 2);
  CHECK(volume[2] == doctest::Approx(-enclosed_volume(outer.points, outer.triangles) +
                                     enclosed_volume(inner.points, inner.triangles)).epsilon(1e-9));
  CHECK(volume[3] == doctest::Approx(-enclosed_volume(inner.points, inner.triangles)).epsilon(1e-9));
}

// Per region the volume of its tets, and per face (its vertices sorted) the regions of the tets on it.
struct Tally {
  std::map<int, double> volume;
  std::map<std::array<uint32_t, 3>, std::multiset<int>> faces;
};
Tally tally(const mesh::Tets& T) {
  Tally out;
  for (size_t i = 0; i < T.tets.size(); ++i) {
    out.volume[T.region[i]] += tet_volume(T.points, T.tets[i]);
    for (int c = 0; c < 4; ++c) {
      std::array<uint32_t, 3> f = {T.tets[i][size_t((c + 1) % 4)], T.tets[i][size_t((c + 2) % 4)],
                                   T.tets[i][size_t((c + 3) % 4)]};
      std::sort(f.begin(), f.end());
      out.faces[f].insert(T.region[i]);
    }
  }
  return out;
}

}  // namespace

TEST_CASE("split_material: a sphere in three pieces, closed, sharing their separators, filling it exactly") {
  const Sphere s = icosphere(10.0, 4, false);
  const auto split = mesh::split_material(s.points, s.triangles, 3, uint32_t(s.points.size()));
  REQUIRE(split.refused.empty());
  REQUIRE(split.pieces.size() == 3);
  REQUIRE(split.planes.size() == 2);
  CHECK(split.separator_triangles > 0);
  std::vector<glm::dvec3> all = s.points;
  all.insert(all.end(), split.points.begin(), split.points.end());
  // The planes cut the longest extent (here any axis) at about the thirds of the vertices.
  CHECK(split.planes[0] < 0);
  CHECK(split.planes[1] > 0);
  for (const auto& p : split.points)  // the lattice points lie on the planes
    CHECK((p[split.axis] == split.planes[0] || p[split.axis] == split.planes[1]));
  std::map<std::array<uint32_t, 3>, int> used;  // oriented face -> count over the pieces
  size_t boundary = 0;
  double sum = 0;
  for (size_t p = 0; p < 3; ++p) {
    CAPTURE(p);
    CHECK(mesh::odd_edges(split.pieces[p]) == 0);
    CHECK(split.volumes[p] == doctest::Approx(enclosed_volume(all, split.pieces[p])).epsilon(1e-12));
    CHECK(split.volumes[p] > 0.2 * enclosed_volume(s.points, s.triangles));
    sum += split.volumes[p];
    for (const auto& f : split.pieces[p]) {
      boundary += std::find(s.triangles.begin(), s.triangles.end(), f) != s.triangles.end();
      ++used[f];
    }
    // TetGen fills each piece exactly, keeping its boundary (-Y).
    const mesh::Tets V = mesh::constrained_quality(all, split.pieces[p], {}, {}, mesh::QualityOptions{});
    double filled = 0;
    for (const auto& t : V.tets) filled += tet_volume(V.points, t);
    CHECK(filled == doctest::Approx(split.volumes[p]).epsilon(1e-9));
  }
  CHECK(boundary == s.triangles.size());  // every boundary triangle in exactly one piece
  CHECK(sum == doctest::Approx(enclosed_volume(s.points, s.triangles)).epsilon(1e-12));
  // Each separator triangle bounds two pieces, once each way round.
  for (const auto& [f, n] : used) {
    const bool on_boundary = std::find(s.triangles.begin(), s.triangles.end(), f) != s.triangles.end();
    CHECK(n == 1);
    if (!on_boundary) CHECK(used.count({f[0], f[2], f[1]}) == 1);
  }
}

TEST_CASE("split_material: refuses an open boundary and a single piece") {
  Sphere s = icosphere(5.0, 2, false);
  CHECK(!mesh::split_material(s.points, s.triangles, 1, uint32_t(s.points.size())).refused.empty());
  s.triangles.pop_back();
  const auto split = mesh::split_material(s.points, s.triangles, 2, uint32_t(s.points.size()));
  CHECK(split.refused.find("not closed") != std::string::npos);
  CHECK(split.pieces.empty());
  CHECK(split.points.empty());
}

TEST_CASE("split_material: refuses a cut across a thin layer") {
  // A shell 0.7 thick (about an edge length): no lattice point fits, so every separator triangle joins boundary
  // vertices, and both pieces would have to keep triangles spanning the layer.
  const Sphere outer = icosphere(10.0, 4, false), inner = icosphere(9.3, 4, true);
  std::vector<glm::dvec3> points = outer.points;
  std::vector<std::array<uint32_t, 3>> boundary = outer.triangles;
  const auto base = uint32_t(points.size());
  points.insert(points.end(), inner.points.begin(), inner.points.end());
  for (auto t : inner.triangles) {
    for (auto& v : t) v += base;
    boundary.push_back(t);
  }
  const auto split = mesh::split_material(points, boundary, 2, uint32_t(points.size()));
  CHECK(split.refused.find("thin layers") != std::string::npos);
  CHECK(split.pieces.empty());
  // The same shell 6 thick is cut.
  const Sphere thick = icosphere(4.0, 3, true);
  points = outer.points;
  boundary = outer.triangles;
  points.insert(points.end(), thick.points.begin(), thick.points.end());
  for (auto t : thick.triangles) {
    for (auto& v : t) v += base;
    boundary.push_back(t);
  }
  const auto cut = mesh::split_material(points, boundary, 2, uint32_t(points.size()));
  CHECK(cut.refused.empty());
  CHECK(cut.separator_on_boundary * 10 < cut.separator_triangles);
}

namespace {

// An ellipsoid 1.5 times as long along x as across, holding flat cavities (spheres of radius 3 squashed to 0.12 of
// their size along x, |x - centre| <= 0.36) at the given x: their two sides face along x, so a plane through one
// would meet them at a grazing angle.
Sphere ellipsoid_with_flat_cavities(const std::vector<double>& centres) {
  Sphere out = icosphere(10.0, 5, false);
  for (auto& p : out.points) p.x *= 1.5;
  for (double x : centres) {
    Sphere cavity = icosphere(3.0, 2, true);
    const auto base = uint32_t(out.points.size());
    for (auto p : cavity.points) out.points.push_back(glm::dvec3(p.x * 0.12 + x, p.y, p.z));
    for (auto t : cavity.triangles) out.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  }
  return out;
}

// How far plane c keeps from the centroids of the triangles whose normals lie within 37 degrees of x.
double grazing_distance(const Sphere& s, double c) {
  double nearest = 1e9;
  for (const auto& t : s.triangles) {
    const glm::dvec3 n = glm::normalize(glm::cross(s.points[t[1]] - s.points[t[0]], s.points[t[2]] - s.points[t[0]]));
    if (std::fabs(n.x) >= 0.8) nearest = std::min(nearest, std::fabs((s.points[t[0]].x + s.points[t[1]].x + s.points[t[2]].x) / 3 - c));
  }
  return nearest;
}

double mean_edge(const Sphere& s) {
  double sum = 0;
  for (const auto& t : s.triangles)
    sum += glm::length(s.points[t[0]] - s.points[t[1]]) + glm::length(s.points[t[1]] - s.points[t[2]]) +
           glm::length(s.points[t[2]] - s.points[t[0]]);
  return sum / (3.0 * double(s.triangles.size()));
}

// The pieces close and fill the material.
void check_pieces(const Sphere& s, const mesh::MaterialSplit& split) {
  std::vector<glm::dvec3> all = s.points;
  all.insert(all.end(), split.points.begin(), split.points.end());
  double sum = 0;
  for (const auto& piece : split.pieces) {
    CHECK(mesh::odd_edges(piece) == 0);
    sum += enclosed_volume(all, piece);
  }
  CHECK(sum == doctest::Approx(enclosed_volume(s.points, s.triangles)).epsilon(1e-12));
}

// The estimated work (mesh::estimated_tets) of the part of closed surface s below the plane x = c, found apart from
// split_material's prefix sums: its vertices below c, and its volume below c exactly (each triangle clipped to
// x < c, cones from a point on the plane, so that the cap adds nothing).
double work_below(const Sphere& s, double c) {
  size_t below = 0;
  for (const auto& p : s.points) below += p.x < c;
  const glm::dvec3 apex(c, 0, 0);
  double volume = 0;
  for (const auto& t : s.triangles) {
    std::vector<glm::dvec3> polygon;
    for (int e = 0; e < 3; ++e) {
      const glm::dvec3 &p = s.points[t[size_t(e)]], &q = s.points[t[size_t((e + 1) % 3)]];
      if (p.x < c) polygon.push_back(p);
      if ((p.x < c) != (q.x < c)) polygon.push_back(p + (q - p) * ((c - p.x) / (q.x - p.x)));
    }
    for (size_t k = 1; k + 1 < polygon.size(); ++k)
      volume += glm::dot(polygon[0] - apex, glm::cross(polygon[k] - apex, polygon[k + 1] - apex)) / 6;
  }
  return mesh::estimated_tets(double(below), volume, mean_edge(s));
}

}  // namespace

TEST_CASE("split_material: the planes lie at quantiles of the estimated work, not of the vertices") {
  // A sphere stretched to three times its length on the side x > 0: as many vertices on either side of x = 0, three
  // times the volume on the stretched side. Nothing grazes a plane near the middle (the normals there are across x).
  Sphere s = icosphere(10.0, 5, false);
  for (auto& p : s.points)
    if (p.x > 0) p.x *= 3;
  const auto split = mesh::split_material(s.points, s.triangles, 2, uint32_t(s.points.size()));
  INFO(split.refused);
  REQUIRE(split.refused.empty());
  REQUIRE(split.planes.size() == 1);
  REQUIRE(split.axis == 0);
  const double plane = split.planes[0], total = work_below(s, 1e9);
  size_t below = 0;
  for (const auto& p : s.points) below += p.x < plane;
  MESSAGE("plane at x = " << plane << ": " << double(below) / double(s.points.size()) << " of the vertices below, "
                          << work_below(s, plane) / total << " of the work");
  CHECK(work_below(s, plane) == doctest::Approx(total / 2).epsilon(0.002));
  // Not the vertices' median (at x = 0, where a ring of vertices lies): the stretched side's volume draws the plane
  // into it, past that ring.
  size_t at_or_below_middle = 0;
  for (const auto& p : s.points) at_or_below_middle += p.x <= 0;
  CHECK(below > at_or_below_middle + 20);
  CHECK(total == doctest::Approx(mesh::estimated_tets(double(s.points.size()), enclosed_volume(s.points, s.triangles),
                                                      mean_edge(s))));
  check_pieces(s, split);
}

TEST_CASE("split_material: a plane moves off boundary that runs parallel to it, to the nearer side, within its slack") {
  // A cavity a little off the middle (either way): the median plane would cut through it; it goes to the nearer
  // place beside it where nothing grazes (3 mean edge lengths from the cavity's sides), so the side depends on the
  // shift.
  for (double shift : {0.3, -0.3}) {
    CAPTURE(shift);
    const Sphere s = ellipsoid_with_flat_cavities({shift});
    const auto split = mesh::split_material(s.points, s.triangles, 2, uint32_t(s.points.size()));
    INFO(split.refused);
    REQUIRE(split.refused.empty());
    REQUIRE(split.planes.size() == 1);
    CHECK(split.axis == 0);
    const double plane = split.planes[0], edge = mean_edge(s), nearest = grazing_distance(s, plane);
    MESSAGE("plane at x = " << plane << ", " << nearest / edge << " mean edges from the nearest grazing triangle");
    CHECK(nearest > 2.5 * edge);
    CHECK(nearest < 3.5 * edge);          // the nearest such place to the middle
    CHECK(plane * shift < 0);             // on the side away from the cavity's centre (nearer the median)
    CHECK(std::fabs(plane - shift) > 0.36);
    // Within the slack (a quarter of a piece's share): each piece keeps 3/8-5/8 of the estimated work.
    const double share = work_below(s, plane) / work_below(s, 1e9);
    CHECK(share >= 3.0 / 8 - 0.002);
    CHECK(share <= 5.0 / 8 + 0.002);
    check_pieces(s, split);
  }
}

TEST_CASE("split_material: in three pieces both planes move off their cavities, in order, each piece within its window") {
  // Cavities at about the thirds of the vertices (the ellipsoid's vertices spread evenly along x over [-15, 15]).
  const Sphere s = ellipsoid_with_flat_cavities({-5.0, 5.2});
  const auto split = mesh::split_material(s.points, s.triangles, 3, uint32_t(s.points.size()));
  INFO(split.refused);
  REQUIRE(split.refused.empty());
  REQUIRE(split.planes.size() == 2);
  CHECK(split.planes[0] < split.planes[1]);
  const double edge = mean_edge(s), total = work_below(s, 1e9);
  for (int j = 0; j < 2; ++j) {
    CAPTURE(j);
    CHECK(grazing_distance(s, split.planes[size_t(j)]) > 2.5 * edge);
  }
  // Every piece keeps 3/4 to 5/4 of its share (a third of the work; kLargestPiece), the last one too.
  const std::vector<double> at = {-1e9, split.planes[0], split.planes[1], 1e9};
  for (size_t p = 0; p < 3; ++p) {
    CAPTURE(p);
    const double shares = 3 * (work_below(s, at[p + 1]) - work_below(s, at[p])) / total;
    CHECK(shares >= 0.75 - 0.01);
    CHECK(shares <= mesh::kLargestPiece + 0.01);
  }
  check_pieces(s, split);
}

TEST_CASE("split_material: `largest` bounds a piece's work where its plane moves off grazing boundary") {
  // The cavity just above the middle: the nearest place clear of it lies below, where the upper piece would take
  // about 1.1 shares. Allowed 1.2 shares, the plane goes there; allowed 1.04, both pieces stay within 1.04 shares
  // and the plane keeps grazing the cavity (no place clear of it lies that near the middle).
  const Sphere s = ellipsoid_with_flat_cavities({0.3});
  const double total = work_below(s, 1e9), edge = mean_edge(s);
  auto upper_shares = [&](double plane) { return 2 * (total - work_below(s, plane)) / total; };
  const auto free = mesh::split_material(s.points, s.triangles, 2, uint32_t(s.points.size()), 1.2);
  REQUIRE(free.refused.empty());
  CHECK(grazing_distance(s, free.planes[0]) > 2.5 * edge);
  CHECK(upper_shares(free.planes[0]) > 1.04);
  CHECK(upper_shares(free.planes[0]) <= 1.2 + 0.01);
  const auto tight = mesh::split_material(s.points, s.triangles, 2, uint32_t(s.points.size()), 1.04);
  REQUIRE(tight.refused.empty());
  MESSAGE("upper piece: " << upper_shares(free.planes[0]) << " shares allowed 1.2, " << upper_shares(tight.planes[0])
                          << " allowed 1.04");
  CHECK(upper_shares(tight.planes[0]) <= 1.04 + 0.01);
  CHECK(upper_shares(tight.planes[0]) >= 0.96 - 0.01);
  CHECK(grazing_distance(s, tight.planes[0]) < 2.5 * edge);
  check_pieces(s, free);
  check_pieces(s, tight);
  CHECK_THROWS_AS(mesh::split_material(s.points, s.triangles, 2, uint32_t(s.points.size()), 0.9), std::invalid_argument);
}

TEST_CASE("split_material: a moved plane stays within `largest` where the candidates lie far apart") {
  // The vertices' x on a grid of 0.25 (a voxel surface's layers, each about a tenth of a share): the window's last
  // candidate must not be the first one past `largest` (it was, at 1.110 shares).
  Sphere s = ellipsoid_with_flat_cavities({-0.3});
  for (auto& p : s.points) p.x = std::round(p.x * 4) / 4;
  const double total = work_below(s, 1e9);
  const auto split = mesh::split_material(s.points, s.triangles, 2, uint32_t(s.points.size()), 1.1);
  INFO(split.refused);
  REQUIRE(split.refused.empty());
  const double lower = 2 * work_below(s, split.planes[0]) / total;
  MESSAGE("lower piece " << lower << " shares, upper " << 2 - lower);
  CHECK(lower <= 1.1 + 1e-9);
  CHECK(2 - lower <= 1.1 + 1e-9);
  check_pieces(s, split);
}

TEST_CASE("material_work: each material's estimated tets from its boundary, the volume signed by the normals") {
  // Material 1 the shell between spheres of radius 10 and 4, material 2 the ball inside, material 0 outside (its
  // boundary encloses it from outside: a negative volume, counted as none); no triangle bounds material 3.
  const Sphere outer = icosphere(10.0, 4, true), inner = icosphere(4.0, 3, true);
  const auto [points, triangles, pair] = nested(outer, inner);
  const auto work = mesh::material_work(points, triangles, pair, 4);
  REQUIRE(work.size() == 4);
  const double n_outer = double(outer.triangles.size()), n_inner = double(inner.triangles.size());
  const double e_outer = mean_edge(outer), e_inner = mean_edge(inner);
  const double shell_edge = (e_outer * n_outer + e_inner * n_inner) / (n_outer + n_inner);
  const double shell = -enclosed_volume(outer.points, outer.triangles) + enclosed_volume(inner.points, inner.triangles);
  CHECK(work[0] == doctest::Approx(mesh::estimated_tets(n_outer / 2, 0.0, e_outer)).epsilon(1e-9));
  CHECK(work[1] == doctest::Approx(mesh::estimated_tets((n_outer + n_inner) / 2, shell, shell_edge)).epsilon(1e-9));
  CHECK(work[2] == doctest::Approx(mesh::estimated_tets(n_inner / 2, -enclosed_volume(inner.points, inner.triangles),
                                                        e_inner)).epsilon(1e-9));
  CHECK(work[2] > mesh::estimated_tets(n_inner / 2, 0.0, e_inner));  // the volume counts
  CHECK(work[3] == 0.0);
}

TEST_CASE("share_runs: one run at a time to the largest, adding up to the runs asked, pieces kept large enough") {
  // The head's three seeded materials (estimated tets, millions) on 16 runs: 7 + 6 + 3, the largest run 1.03 M.
  const std::vector<double> head = {7.19, 5.28, 3.01};
  const std::vector<size_t> many(3, 1'000'000);
  CHECK(mesh::share_runs(head, many, 16, 20'000) == std::vector<int>{7, 6, 3});
  // No other split of 16 runs has a smaller largest run (every move of one run from a material to another).
  auto largest = [&](const std::vector<int>& k) {
    double most = 0;
    for (size_t j = 0; j < k.size(); ++j) most = std::max(most, head[j] / k[j]);
    return most;
  };
  const std::vector<int> best = mesh::share_runs(head, many, 16, 20'000);
  for (size_t from = 0; from < 3; ++from)
    for (size_t to = 0; to < 3; ++to) {
      if (from == to || best[from] == 1) continue;
      std::vector<int> k = best;
      --k[from];
      ++k[to];
      CHECK(largest(k) >= largest(best));
    }
  // As many runs as materials, or fewer: one each.
  CHECK(mesh::share_runs(head, many, 3, 20'000) == std::vector<int>{1, 1, 1});
  CHECK(mesh::share_runs(head, many, 2, 20'000) == std::vector<int>{1, 1, 1});
  // A material of 50,000 triangles takes at most 2 pieces of 20,000; the other runs go to the rest.
  CHECK(mesh::share_runs({10.0, 1.0}, {50'000, 1'000'000}, 8, 20'000) == std::vector<int>{2, 6});
  // Nobody can take more: fewer runs than asked.
  CHECK(mesh::share_runs({10.0, 1.0}, {50'000, 30'000}, 8, 20'000) == std::vector<int>{2, 1});
}

TEST_CASE("mesh_materials: a shell cut into pieces meshes like one run: same volumes, conforming, slivers fixed") {
  // Material 1 between spheres of radius 10 and 4, material 2 inside; the inner sphere is a cavity that the pieces
  // of material 1 must carve out with material 2's seed. Jittered spheres leave boundary triangles that are no
  // Delaunay faces: the split must see them (or refuse) and never make a wrong mesh.
  for (const double jitter : {0.0, 0.15}) {
    CAPTURE(jitter);
    const Sphere outer = icosphere(10.0, 4, true, jitter, 3), inner = icosphere(4.0, 3, true, jitter, 4);
    const auto [points, triangles, pair] = nested(outer, inner);
    const std::vector<mesh::Region> seeds = {{glm::dvec3(7.0, 0.0, 0.0), 2}, {glm::dvec3(0.0), 3}};
    const std::vector<uint16_t> labels = {0, 1, 2};
    mesh::QualityOptions options;
    options.runs = 1;
    const auto whole = mesh::mesh_materials(points, triangles, pair, seeds, labels, options);
    options.runs = 4;
    options.min_piece_triangles = 1000;
    const auto cut = mesh::mesh_materials(points, triangles, pair, seeds, labels, options);
    CHECK(whole.runs.size() == 2);
    size_t pieces = 0;
    for (const auto& run : cut.runs) pieces += run.material == 1 && run.pieces > 1;
    MESSAGE("jitter " << jitter << ": " << pieces << " pieces of material 1; " << cut.tets.tets.size() << " tets against "
                      << whole.tets.tets.size() << " whole; min dihedral " << cut.improvement.min_dihedral_after
                      << " (whole " << whole.improvement.min_dihedral_after << "), below 12: " << cut.sliver_split.failed
                      << " (whole " << whole.sliver_split.failed << "), remeshed " << cut.sliver_split.remeshed
                      << (cut.unsplit_because.empty() ? "" : "; " + cut.unsplit_because[0]));
    if (jitter == 0.0) {
      CHECK(pieces >= 2);
      CHECK(cut.unsplit_because.empty());
      CHECK(cut.separator_points > 0);
    }
    // Volumes per material equal the whole runs' (and the surfaces' enclosed volumes).
    for (const auto* r : {&whole, &cut}) {
      const mesh::Tets& T = r->tets;
      REQUIRE(T.region.size() == T.tets.size());
      auto [volume, faces] = tally(T);
      check_nested_volumes(volume, outer, inner);
      // Conforming: each interface triangle is a face of one tet of each meshed material beside it; every other
      // face of a tet is shared by two tets of one material or by none (none: the outer hull).
      for (size_t i = 0; i < triangles.size(); ++i) {
        auto f = triangles[i];
        std::sort(f.begin(), f.end());
        std::multiset<int> expect;
        for (uint16_t m : pair[i])
          if (m > 0) expect.insert(int(m) + 1);
        CHECK(faces[f] == expect);
      }
      size_t unpaired = 0;
      for (const auto& [f, who] : faces) unpaired += who.size() == 1;
      CHECK(unpaired == outer.triangles.size());  // the outer sphere only: no gap along a separator
      CHECK(mesh::tet_stats(T.points, T.tets).min_dihedral_deg >= 10.0);
      CHECK(r->sliver_split.failed == mesh::count_below_dihedral(T.points, T.tets, options.min_dihedral));
    }
  }
}

TEST_CASE("mesh_materials: a refused cut meshes its material whole beside another material's pieces") {
  // Material 1 a shell 0.7 thick between spheres of radius 10 and 9.3 (its cut is refused: thin layers), material 2
  // the ball inside (cut in pieces). The merge numbers material 2's separator points right after the surfaces'.
  const Sphere outer = icosphere(10.0, 4, true), inner = icosphere(9.3, 4, true);
  const auto [points, triangles, pair] = nested(outer, inner);
  const std::vector<mesh::Region> seeds = {{glm::dvec3(9.65, 0.0, 0.0), 2}, {glm::dvec3(0.0), 3}};
  const std::vector<uint16_t> labels = {0, 7, 9};
  mesh::QualityOptions options;
  options.runs = 6;
  options.min_piece_triangles = 1000;
  const auto r = mesh::mesh_materials(points, triangles, pair, seeds, labels, options);
  REQUIRE(r.unsplit_because.size() == 1);
  CHECK(r.unsplit_because[0].find("material 7 meshed whole") == 0);
  CHECK(r.unsplit_because[0].find("thin layers") != std::string::npos);
  CHECK(r.one_run_because.empty());
  size_t whole = 0, pieces = 0;
  for (const auto& run : r.runs) {
    whole += run.material == 1 && run.pieces == 1;
    pieces += run.material == 2 && run.pieces > 1;
  }
  CHECK(whole == 1);
  CHECK(pieces >= 2);
  CHECK(r.separator_points > 0);
  // The runs in material order; the surfaces' points first and unchanged; the volumes per material; conforming.
  CHECK(r.runs.front().material == 1);
  const mesh::Tets& T = r.tets;
  REQUIRE(T.points.size() >= points.size());
  CHECK(std::equal(points.begin(), points.end(), T.points.begin()));
  REQUIRE(T.region.size() == T.tets.size());
  auto [volume, faces] = tally(T);
  check_nested_volumes(volume, outer, inner);
  size_t unpaired = 0, mixed = 0;
  for (const auto& [f, who] : faces) {
    unpaired += who.size() == 1;
    mixed += who.size() == 2 && *who.begin() != *who.rbegin();
  }
  CHECK(unpaired == outer.triangles.size());
  CHECK(mixed == inner.triangles.size());
  CHECK(r.sliver_split.failed == mesh::count_below_dihedral(T.points, T.tets, options.min_dihedral));
}

TEST_CASE("split_material: boundary triangles that are no Delaunay faces are seen, and the pieces stay closed") {
  // Flipping an icosphere edge leaves the two new triangles without an empty sphere (the old diagonal had it): 20
  // flips near the plane x = 0 where the cut goes (the sphere's extents tie, so the axis is x).
  Sphere s = icosphere(10.0, 4, false);
  std::map<std::pair<uint32_t, uint32_t>, size_t> edge_of;  // directed edge -> triangle
  for (size_t t = 0; t < s.triangles.size(); ++t)
    for (int e = 0; e < 3; ++e) edge_of[{s.triangles[t][size_t(e)], s.triangles[t][size_t((e + 1) % 3)]}] = t;
  std::set<uint32_t> touched;
  int flips = 0;
  for (size_t t = 0; t < s.triangles.size() && flips < 20; ++t) {
    const auto [a, b, c] = s.triangles[t];
    const size_t u = edge_of.at({b, a});
    uint32_t d = 0;
    for (uint32_t v : s.triangles[u])
      if (v != a && v != b) d = v;
    const std::set<uint32_t> quad = {a, b, c, d};
    if (std::fabs((s.points[a] + s.points[b] + s.points[c] + s.points[d]).x / 4) > 2.0) continue;
    if (std::any_of(quad.begin(), quad.end(), [&](uint32_t v) { return touched.count(v) > 0; })) continue;
    s.triangles[t] = {c, a, d};
    s.triangles[u] = {d, b, c};
    touched.insert(quad.begin(), quad.end());
    ++flips;
  }
  REQUIRE(flips == 20);
  REQUIRE(mesh::odd_edges(s.triangles) == 0);
  const auto split = mesh::split_material(s.points, s.triangles, 2, uint32_t(s.points.size()));
  MESSAGE(split.gap_triangles << " gap triangles; " << (split.refused.empty() ? "split" : split.refused));
  if (!split.refused.empty()) {
    CHECK(split.refused.find("crosses") != std::string::npos);
    return;
  }
  CHECK(split.gap_triangles >= 20);
  std::vector<glm::dvec3> all = s.points;
  all.insert(all.end(), split.points.begin(), split.points.end());
  double sum = 0;
  for (size_t p = 0; p < 2; ++p) {
    CHECK(mesh::odd_edges(split.pieces[p]) == 0);
    sum += split.volumes[p];
    // The pieces fill their boundaries exactly: the separator went around the gaps, not through them.
    const mesh::Tets V = mesh::constrained_quality(all, split.pieces[p], {}, {}, mesh::QualityOptions{});
    double filled = 0;
    for (const auto& t : V.tets) filled += tet_volume(V.points, t);
    CHECK(filled == doctest::Approx(split.volumes[p]).epsilon(1e-9));
  }
  CHECK(sum == doctest::Approx(enclosed_volume(s.points, s.triangles)).epsilon(1e-12));
}
