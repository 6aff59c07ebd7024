// mesh::parallel_delaunay against TetGen and against the Delaunay property itself; then mesh::DelaunayMesh::insert:
// points inserted into a built mesh give the tetrahedralization of all the points (unique in general position).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <thread>

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include "mesh/delaunay.h"
#include "mesh/extract.h"
#include "mesh/tetgen.h"

using namespace cpmesh;

namespace {

std::vector<std::array<uint32_t, 4>> sorted_tets(const mesh::Tets& T) {
  auto tets = T.tets;
  for (auto& t : tets) std::sort(t.begin(), t.end());
  std::sort(tets.begin(), tets.end());
  return tets;
}

}  // namespace

// ---- parallel_delaunay (mesh/delaunay.h) ----

namespace {

double signed_volume(const mesh::Tets& T, const std::array<uint32_t, 4>& t) {
  const glm::dvec3 a = T.points[t[0]];
  return glm::dot(T.points[t[1]] - a, glm::cross(T.points[t[2]] - a, T.points[t[3]] - a)) / 6.0;
}

// Checks the tetrahedralization as a whole, independently of how it was built: every tet oriented as TetGen's,
// neighbours symmetric and sharing the face, every inner face locally Delaunay (exact), and the volume (where given).
void check_delaunay(const mesh::Tets& T, double hull_volume) {
  REQUIRE(T.neighbours.size() == T.tets.size() * 4);
  size_t flat_or_flipped = 0, asymmetric = 0, not_delaunay = 0;
  double volume = 0;
  for (size_t t = 0; t < T.tets.size(); ++t) {
    const auto& v = T.tets[t];
    flat_or_flipped += !(mesh::orient3d_exact(T.points[v[0]], T.points[v[1]], T.points[v[2]], T.points[v[3]]) < 0);
    volume += signed_volume(T, v);
    for (int c = 0; c < 4; ++c) {
      const int32_t n = T.neighbours[t * 4 + size_t(c)];
      if (n < 0) continue;
      const auto& u = T.tets[size_t(n)];
      // The neighbour holds the three other corners and names t back across the face.
      int shared = 0, apex = -1;
      for (int k = 0; k < 4; ++k) {
        const bool in_t = std::find(v.begin(), v.end(), u[size_t(k)]) != v.end();
        shared += in_t;
        if (!in_t) apex = k;
      }
      asymmetric += shared != 3 || T.neighbours[size_t(n) * 4 + size_t(apex)] != int32_t(t) ||
                    std::find(u.begin(), u.end(), v[size_t(c)]) != u.end();
      // TetGen's orientation is negative: insphere's sign flips.
      not_delaunay += mesh::insphere_exact(T.points[v[0]], T.points[v[1]], T.points[v[2]], T.points[v[3]],
                                           T.points[u[size_t(apex)]]) < 0;
    }
  }
  CHECK(flat_or_flipped == 0);
  CHECK(asymmetric == 0);
  CHECK(not_delaunay == 0);
  if (hull_volume > 0) CHECK(volume == doctest::Approx(hull_volume).epsilon(1e-9));
}

// Integer points exactly on the sphere of radius r = a^2 + b^2 + c^2 + d^2 about the origin (a quaternion's rotation
// of (r, 0, 0)): every five of them cospherical, the most degenerate input there is.
std::vector<glm::dvec3> integer_sphere_points(long r, size_t count, unsigned seed) {
  std::mt19937_64 rng(seed);
  const long lim = long(std::sqrt(double(r)));
  std::uniform_int_distribution<long> u(-lim, lim);
  std::vector<glm::dvec3> out;
  while (out.size() < count) {
    const long a = u(rng), b = u(rng), c = u(rng), rest = r - a * a - b * b - c * c;
    if (rest < 0) continue;
    long d = std::lround(std::sqrt(double(rest)));
    if (d * d != rest) continue;
    if (rng() & 1) d = -d;
    out.push_back(glm::dvec3(double(a * a + b * b - c * c - d * d), double(2 * (a * d + b * c)), double(2 * (b * d - a * c))));
  }
  return out;
}

}  // namespace

TEST_CASE("parallel_delaunay: random points (and exact duplicates) give TetGen's tets, whatever the thread count") {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<glm::dvec3> points;
  for (int i = 0; i < 20000; ++i) points.push_back(glm::dvec3(u(rng), u(rng), u(rng)));
  const mesh::Tets tetgen = mesh::delaunay(points);
  // Exact duplicates of earlier points, appended: the first of each is meshed (TetGen keeps whichever it met first
  // in its own random order), so the tets are the same as without them.
  for (int i = 0; i < 30; ++i) points.push_back(points[size_t(100 + 37 * i)]);
  mesh::DelaunayStats stats;
  const mesh::Tets ours = mesh::parallel_delaunay(points, &stats);
  CHECK_FALSE(stats.fell_back);
  CHECK(stats.duplicates == 30);
  CHECK(stats.rounds > 100);  // 1,024 points one at a time, then rounds of many
  CHECK(ours.points == points);
  CHECK(sorted_tets(ours) == sorted_tets(tetgen));
  double hull_volume = 0;
  for (const auto& t : tetgen.tets) hull_volume += signed_volume(tetgen, t);
  check_delaunay(ours, hull_volume);
  size_t duplicate_corners = 0;
  for (const auto& t : ours.tets)
    for (uint32_t v : t) duplicate_corners += v >= points.size() - 30;
  CHECK(duplicate_corners == 0);
  // The adjacency from the neighbours equals the one found by sorting the faces.
  mesh::Tets plain = ours;
  plain.neighbours.clear();
  CHECK(mesh::build_adjacency(ours).neighbour == mesh::build_adjacency(plain).neighbour);
  // Reservations make the result depend on the order only: one thread gives the same arrays.
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const mesh::Tets alone = mesh::parallel_delaunay(points);
  CHECK(alone.tets == ours.tets);
  CHECK(alone.neighbours == ours.neighbours);
}

TEST_CASE("parallel_delaunay: a lattice (cospherical and coplanar points, hull faces in planes) meshes without help") {
  // Every unit cube's corners are cospherical and the hull's faces hold whole grids of points: the strict conflicts
  // pick one of the Delaunay tetrahedralizations (TetGen's may differ) with no flat tet.
  std::vector<glm::dvec3> points;
  const int n = 12;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) points.push_back(glm::dvec3(x, y, z) * 0.5);
  mesh::DelaunayStats stats;
  const mesh::Tets T = mesh::parallel_delaunay(points, &stats);
  CHECK_FALSE(stats.fell_back);
  CHECK(stats.why.empty());
  const double side = 0.5 * (n - 1);
  check_delaunay(T, side * side * side);
  // Every point is a corner of some tet; 5 or 6 tets per unit cube.
  std::vector<uint8_t> used(points.size(), 0);
  for (const auto& t : T.tets)
    for (uint32_t v : t) used[v] = 1;
  CHECK(std::count(used.begin(), used.end(), 0) == 0);
  const size_t cubes = size_t(n - 1) * (n - 1) * (n - 1);
  CHECK(T.tets.size() >= 5 * cubes);
  CHECK(T.tets.size() <= 6 * cubes);
}

TEST_CASE("parallel_delaunay: few points, flat sets and bad coordinates") {
  CHECK_THROWS_AS(mesh::parallel_delaunay({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}), std::runtime_error);
  CHECK_THROWS_AS(mesh::parallel_delaunay({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, std::nan("")}}), std::runtime_error);
  // One tet, and four points with a duplicate.
  const mesh::Tets one = mesh::parallel_delaunay({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}});
  REQUIRE(one.tets.size() == 1);
  CHECK(one.neighbours == std::vector<int32_t>{-1, -1, -1, -1});
  check_delaunay(one, 1.0 / 6.0);
  // Points on one plane: an error, not a crash (TetGen asserts on a flat bounding box, and delaunay() checks first).
  std::vector<glm::dvec3> flat, tilted;
  for (int i = 0; i < 20; ++i) {
    flat.push_back(glm::dvec3(i % 5, i / 5, 0.0));
    tilted.push_back(glm::dvec3(i % 5, i / 5, i % 5 + i / 5));  // the plane z = x + y
  }
  CHECK_THROWS_AS(mesh::delaunay(flat), std::runtime_error);
  CHECK_THROWS_AS(mesh::parallel_delaunay(flat), std::runtime_error);
  CHECK_THROWS_AS(mesh::parallel_delaunay(tilted), std::runtime_error);
}

TEST_CASE("parallel_delaunay: cospherical and coplanar sets TetGen cannot mesh, and far-off scales") {
  // 4,000 integer points on one sphere: all cospherical; then the same points' x and y on 11 planes (TetGen 1.5
  // crashes on such a set). Both are meshed without the fallback, Delaunay by the exact check.
  const auto sphere = integer_sphere_points(5525, 4000, 5);
  mesh::DelaunayStats stats;
  check_delaunay(mesh::parallel_delaunay(sphere, &stats), 0);
  CHECK_FALSE(stats.fell_back);
  std::mt19937_64 rng(7);
  std::vector<glm::dvec3> planes;
  for (const auto& p : sphere)
    if (std::fabs(p.z) < 3000) planes.push_back(glm::dvec3(p.x, p.y, double(long(rng() % 11) - 5) * 1000));
  const mesh::Tets layered = mesh::parallel_delaunay(planes, &stats);
  CHECK_FALSE(stats.fell_back);
  CHECK(stats.duplicates > 0);
  check_delaunay(layered, 0);
  // Coordinates scaled by 2^250 or 2^-250 (exact: no predicate changes sign) give the same tets: the predicates see
  // the points scaled back (insphere's products would overflow or underflow, every test then "not inside").
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<glm::dvec3> points;
  for (int i = 0; i < 3000; ++i) points.push_back(glm::dvec3(u(rng), u(rng), u(rng)));
  const auto reference = sorted_tets(mesh::parallel_delaunay(points));
  for (const int e : {250, -250}) {
    std::vector<glm::dvec3> scaled = points;
    for (auto& p : scaled) p *= std::ldexp(1.0, e);
    const mesh::Tets T = mesh::parallel_delaunay(scaled, &stats);
    CHECK_FALSE(stats.fell_back);
    CHECK(T.points == scaled);
    CHECK(sorted_tets(T) == reference);
  }
  // Points a hair apart far from the origin: refused, not meshed wrong.
  std::vector<glm::dvec3> huddle;
  for (const auto& p : points) huddle.push_back(glm::dvec3(1.0) + p * std::ldexp(1.0, -220));
  CHECK_THROWS_AS(mesh::parallel_delaunay(huddle), std::runtime_error);
}

// ---- DelaunayMesh::insert ----

TEST_CASE("DelaunayMesh::insert: points inserted into a built mesh give TetGen's tets of all the points") {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0.0, 10.0);
  std::vector<glm::dvec3> points;
  for (int i = 0; i < 6000; ++i) points.push_back(glm::dvec3(u(rng), u(rng), u(rng)));
  // Later points beyond the first ones' hull (it must grow) and exactly on a point already meshed, or on one
  // inserted in the same call (duplicates: in no tet).
  const std::vector<glm::dvec3> beyond = {{-1.0, 5.0, 5.0}, {5.0, 11.0, 5.0}, {12.0, 12.0, 12.0}};
  mesh::DelaunayMesh D(std::vector<glm::dvec3>(points.begin(), points.begin() + 4000));
  std::vector<glm::dvec3> more(points.begin() + 4000, points.begin() + 5990);
  more.push_back(points[123]);
  more.push_back(points[4100]);
  D.insert(more);
  D.insert({points.begin() + 5990, points.end()});  // a few, as the repair inserts them
  D.insert(beyond);
  CHECK(D.stats().rebuilds == 0);
  CHECK_FALSE(D.stats().fell_back);
  CHECK(D.stats().duplicates == 2);
  mesh::Adjacency adj;
  const mesh::Tets T = D.tets(&adj);
  // The adjacency given with the tets is the one found from them.
  CHECK(adj.neighbour == mesh::build_adjacency(T).neighbour);
  std::vector<glm::dvec3> given(points.begin(), points.begin() + 5990);
  given.push_back(points[123]);
  given.push_back(points[4100]);
  given.insert(given.end(), points.begin() + 5990, points.end());
  given.insert(given.end(), beyond.begin(), beyond.end());
  CHECK(T.points == given);
  std::vector<glm::dvec3> distinct = points;
  distinct.insert(distinct.end(), beyond.begin(), beyond.end());
  const mesh::Tets all = mesh::delaunay(distinct);
  // The same tets once the duplicates' numbers (5990, 5991) are taken out.
  auto renumbered = T;
  size_t duplicate_corners = 0;
  for (auto& t : renumbered.tets)
    for (auto& v : t) {
      duplicate_corners += v == 5990 || v == 5991;
      if (v > 5991) v -= 2;
    }
  CHECK(duplicate_corners == 0);
  CHECK(sorted_tets(renumbered) == sorted_tets(all));
  double hull_volume = 0;
  for (const auto& t : all.tets) hull_volume += signed_volume(all, t);
  check_delaunay(T, hull_volume);
  // The same arrays on one thread and on eight.
  for (int threads : {1, 8}) {
    CAPTURE(threads);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
    tbb::task_arena arena(threads);
    mesh::Tets A;
    arena.execute([&] {
      mesh::DelaunayMesh again(std::vector<glm::dvec3>(points.begin(), points.begin() + 4000));
      again.insert(more);
      again.insert({points.begin() + 5990, points.end()});
      again.insert(beyond);
      A = again.tets();
    });
    CHECK(A.tets == T.tets);
    CHECK(A.neighbours == T.neighbours);
  }
}

TEST_CASE("DelaunayMesh::insert: a lattice grows in its hull faces' planes; duplicates of hull points stay out") {
  std::vector<glm::dvec3> lattice;
  for (int z = 0; z < 4; ++z)
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 4; ++x) lattice.push_back(glm::dvec3(x, y, z) * 0.25);
  mesh::DelaunayMesh D(lattice);
  // Points in the plane z = 0 beyond the hull (coplanar with hull faces), on the line of a hull edge beyond it, cube
  // centres (cospherical with eight corners each), one below a hull corner, and two lattice points again (hull
  // corners). All coordinates under 1 (the predicates' scale): no rebuild.
  const std::vector<glm::dvec3> more = {{0.375, 0.875, 0.0}, {0.5, -0.125, 0.0},   {0.875, 0.0, 0.0},
                                        {0.125, 0.125, 0.125}, {0.625, 0.375, 0.625}, {0.75, 0.75, -0.125},
                                        {0.75, 0.0, 0.0},      {0.0, 0.0, 0.0}};
  D.insert(more);
  CHECK(D.stats().rebuilds == 0);
  CHECK(D.stats().duplicates == 2);
  const mesh::Tets T = D.tets();
  std::vector<glm::dvec3> all = lattice;
  all.insert(all.end(), more.begin(), more.end());
  CHECK(T.points == all);
  // The hull's volume as TetGen meshes the distinct points; every point but the two duplicates is a corner.
  const mesh::Tets tetgen = mesh::delaunay(std::vector<glm::dvec3>(all.begin(), all.end() - 2));
  double hull_volume = 0;
  for (const auto& t : tetgen.tets) hull_volume += signed_volume(tetgen, t);
  check_delaunay(T, hull_volume);
  std::vector<uint8_t> corner(all.size(), 0);
  for (const auto& t : T.tets)
    for (uint32_t v : t) corner[v] = 1;
  CHECK(std::count(corner.begin(), corner.end(), 1) == long(all.size()) - 2);
  CHECK(corner[all.size() - 1] == 0);
  CHECK(corner[all.size() - 2] == 0);
}

TEST_CASE("DelaunayMesh::insert: far points mesh all afresh, bad ones are refused and change nothing") {
  std::vector<glm::dvec3> points;
  for (int c = 0; c < 8; ++c) points.push_back(glm::dvec3(c & 1, c & 2 ? 1 : 0, c & 4 ? 1 : 0));
  points.push_back(glm::dvec3(0.4, 0.45, 0.5));
  mesh::DelaunayMesh D(points);
  const auto before = D.tets();
  CHECK_THROWS_AS(D.insert({glm::dvec3(0.5, 0.5, std::nan(""))}), std::runtime_error);
  CHECK(D.tets().points == before.points);
  CHECK(D.tets().tets == before.tets);
  CHECK(D.stats().rebuilds == 0);
  // A coordinate of twice the largest power of two under the build's largest or more changes the predicates' scale
  // (1 here): everything is meshed again; under it, the mesh grows.
  D.insert({glm::dvec3(0.6, 0.3, 0.7), glm::dvec3(1.9990234375, 0.5, 0.5)});
  CHECK(D.stats().rebuilds == 0);
  D.insert({glm::dvec3(3.0, 0.5, 0.5)});
  CHECK(D.stats().rebuilds == 1);
  points.push_back(glm::dvec3(0.6, 0.3, 0.7));
  points.push_back(glm::dvec3(1.9990234375, 0.5, 0.5));
  points.push_back(glm::dvec3(3.0, 0.5, 0.5));
  const mesh::Tets T = D.tets();
  CHECK(T.points == points);
  double hull_volume = 0;
  const mesh::Tets all = mesh::delaunay(points);
  for (const auto& t : all.tets) hull_volume += signed_volume(all, t);
  check_delaunay(T, hull_volume);
  CHECK(hull_volume == doctest::Approx(1.0 + 2.0 / 3.0));  // the unit cube and a pyramid of height 2 on a face
  // After the rebuild, insertions go on into the mesh.
  D.insert({glm::dvec3(0.2, 0.8, 0.3)});
  CHECK(D.stats().rebuilds == 1);
  CHECK(D.tets().points.size() == points.size() + 1);
}

// ---- FilteredPredicates (tetgen.h) ----

TEST_CASE("FilteredPredicates: the floating-point answers it gives agree in sign with the exact predicates") {
  // Random points (mostly answered by the filters) and points on a small integer grid, some nudged by an ulp
  // (coplanar and cospherical sets, answered exactly), in a box of extent 8 around (100, -50, 3).
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.0, 8.0);
  std::uniform_int_distribution<int> grid(0, 4), pick(0, 3);
  const glm::dvec3 origin(100.0, -50.0, 3.0);
  const mesh::FilteredPredicates pred(glm::dvec3(8.0));
  auto point = [&] {
    if (pick(rng) == 0) return origin + glm::dvec3(u(rng), u(rng), u(rng));
    glm::dvec3 p = origin + 2.0 * glm::dvec3(grid(rng), grid(rng), grid(rng));
    if (pick(rng) == 0) p.x = std::nextafter(p.x, 1e9);
    return p;
  };
  size_t orient_zero = 0, insphere_zero = 0, orient_wrong = 0, insphere_wrong = 0;
  auto sign = [](double x) { return (x > 0) - (x < 0); };
  for (int i = 0; i < 200000; ++i) {
    const glm::dvec3 a = point(), b = point(), c = point(), d = point(), e = point();
    const double o = mesh::orient3d_exact(a, b, c, d), s = mesh::insphere_exact(a, b, c, d, e);
    orient_zero += o == 0;
    insphere_zero += s == 0;
    orient_wrong += sign(pred.orient3d(a, b, c, d)) != sign(o);
    insphere_wrong += sign(pred.insphere(a, b, c, d, e)) != sign(s);
  }
  MESSAGE(orient_zero << " coplanar and " << insphere_zero << " cospherical sets of 200,000");
  CHECK(orient_zero > 1000);  // the exact paths ran
  CHECK(insphere_zero > 1000);
  CHECK(orient_wrong == 0);
  CHECK(insphere_wrong == 0);
  // The extent is widened where an axis is flat.
  CHECK(mesh::FilteredPredicates(glm::dvec3(4.0, 0.0, 2.0)).extent() == glm::dvec3(4.0, 0.004, 2.0));
}

TEST_CASE("DelaunayMesh: meshes built at once on two threads equal the same meshes built alone") {
  // A smoke test of concurrent use (shared scratch or settings between instances would show here); it does not
  // catch every interleaving: one filter bound shared by both (the old process-wide one) passed it, as the build
  // that sets it last may be the one whose bound is safe for both.
  // Point sets of very different extents (their predicates' filters differ by orders of magnitude; the cuts of
  // split_material build such meshes side by side): random points in a box 1e-3 wide, and a lattice of spacing 0.1
  // (cospherical sets whose floating-point determinants are rounding noise: only the exact predicates decide them,
  // and the other mesh's filters would let the noise through).
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<glm::dvec3> small, large;
  for (int i = 0; i < 30000; ++i) small.push_back(glm::dvec3(1000.0) + 1e-3 * glm::dvec3(u(rng), u(rng), u(rng)));
  for (int z = 0; z < 24; ++z)
    for (int y = 0; y < 24; ++y)
      for (int x = 0; x < 24; ++x) large.push_back(glm::dvec3(-5.0) + 0.1 * glm::dvec3(x, y, z));
  const mesh::Tets small_alone = mesh::parallel_delaunay(small), large_alone = mesh::parallel_delaunay(large);
  mesh::DelaunayStats small_stats, large_stats;
  mesh::Tets small_together, large_together;
  std::thread other([&] { large_together = mesh::parallel_delaunay(large, &large_stats); });
  small_together = mesh::parallel_delaunay(small, &small_stats);
  other.join();
  CHECK_FALSE(small_stats.fell_back);
  CHECK_FALSE(large_stats.fell_back);
  CHECK(small_together.tets == small_alone.tets);
  CHECK(small_together.neighbours == small_alone.neighbours);
  CHECK(large_together.tets == large_alone.tets);
  CHECK(large_together.neighbours == large_alone.neighbours);
}
