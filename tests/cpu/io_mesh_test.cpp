// Mesh writers: PLY, Medit and VTU read back exactly (PLY in float precision); OBJ, STL, VTP and TetGen files have the
// counts and tags they should; bad meshes are refused without leaving a file.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "scratch_dir.h"
#include "io/error.h"
#include "io/mesh_readers.h"
#include "io/mesh_writers.h"

namespace fs = std::filesystem;
using namespace cpmesh::io;

namespace {

std::string tmp(const std::string& name) { return (cpmesh::test::scratch_dir("io_mesh") / name).string(); }

std::string read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Two tets sharing a face: material 1 and 2; the shared face is the 1|2 interface, the rest boundary with 0.
TetMesh two_tets() {
  TetMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.25, 0.5, -1.75}};
  m.tets = {{0, 1, 2, 3}, {0, 2, 1, 4}};
  m.tet_material = {1, 2};
  m.triangles = {{0, 1, 2}, {0, 1, 3}, {0, 4, 2}};
  m.triangle_pair = {{1, 2}, {0, 1}, {0, 2}};
  return m;
}

TriangleMesh triangles() {
  const TetMesh t = two_tets();
  TriangleMesh m;
  m.vertices = t.vertices;
  m.triangles = t.triangles;
  m.triangle_pair = t.triangle_pair;
  m.vertex_feature = {0, 1, 1, 2, 2};
  return m;
}

}  // namespace

TEST_CASE("PLY round trip keeps vertices, triangles, pairs and features") {
  const TriangleMesh m = triangles();
  write_ply(tmp("m.ply"), m);
  const TriangleMesh r = read_ply(tmp("m.ply"));
  REQUIRE(r.vertices.size() == m.vertices.size());
  for (size_t v = 0; v < m.vertices.size(); ++v)
    for (int c = 0; c < 3; ++c) CHECK(r.vertices[v][c] == doctest::Approx(m.vertices[v][c]));
  CHECK(r.triangles == m.triangles);
  CHECK(r.triangle_pair == m.triangle_pair);
  CHECK(r.vertex_feature == m.vertex_feature);
}

TEST_CASE("Medit and VTU round trips keep tets and materials") {
  const TetMesh m = two_tets();
  write_medit(tmp("m.mesh"), m);
  const TetMesh r = read_medit(tmp("m.mesh"));
  CHECK(r.vertices == m.vertices);
  CHECK(r.tets == m.tets);
  CHECK(r.tet_material == m.tet_material);
  CHECK(r.triangles == m.triangles);
  CHECK(r.triangle_pair == m.triangle_pair);
  write_vtu(tmp("m.vtu"), m);
  const TetMesh u = read_vtu(tmp("m.vtu"));
  CHECK(u.vertices == m.vertices);
  CHECK(u.tets == m.tets);
  CHECK(u.tet_material == m.tet_material);
}

TEST_CASE("OBJ groups per pair, STL binary size, VTP arrays, TetGen files") {
  const TriangleMesh m = triangles();
  write_obj(tmp("m.obj"), m);
  const std::string obj = read_all(tmp("m.obj"));
  for (const char* g : {"g interface_0_1\n", "g interface_0_2\n", "g interface_1_2\nf 1 2 3\n"})
    CHECK(obj.find(g) != std::string::npos);
  write_stl(tmp("m.stl"), m);
  CHECK(fs::file_size(tmp("m.stl")) == 84 + 50 * m.triangles.size());
  write_vtp(tmp("m.vtp"), m);
  const std::string vtp = read_all(tmp("m.vtp"));
  CHECK(vtp.find("NumberOfPoints=\"5\" NumberOfPolys=\"3\"") != std::string::npos);
  CHECK(vtp.find("Name=\"material_pair\" NumberOfComponents=\"2\"") != std::string::npos);
  CHECK(vtp.find("Name=\"feature\"") != std::string::npos);
  write_triangle_mesh(tmp("by_ext.ply"), m);
  CHECK(read_ply(tmp("by_ext.ply")).triangles == m.triangles);
  CHECK_THROWS_AS(write_triangle_mesh(tmp("m.xyz"), m), Error);

  write_tetgen(tmp("m"), two_tets());
  std::istringstream ele(read_all(tmp("m.ele")));
  int n, per, attrs, id, a, b, c, d, mat;
  ele >> n >> per >> attrs >> id >> a >> b >> c >> d >> mat;
  CHECK((n == 2 && per == 4 && attrs == 1 && id == 1 && a == 1 && d == 4 && mat == 1));
  CHECK(read_all(tmp("m.face")).find("1 1 2 3 1002\n") != std::string::npos);
  CHECK(read_all(tmp("m.node")).rfind("5 3 0 0\n", 0) == 0);
}

TEST_CASE("bad meshes are refused and leave no file") {
  TriangleMesh m = triangles();
  m.triangles.push_back({0, 1, 99});
  m.triangle_pair.push_back({0, 1});
  CHECK_THROWS_WITH_AS(write_ply(tmp("bad.ply"), m), doctest::Contains("uses vertex 99"), Error);
  CHECK(!fs::exists(tmp("bad.ply")));
  TetMesh t = two_tets();
  t.tet_material.pop_back();
  CHECK_THROWS_AS(write_vtu(tmp("bad.vtu"), t), Error);
  CHECK(!fs::exists(tmp("bad.vtu")));
  t = two_tets();
  t.triangle_pair[0] = {1, 1000};
  CHECK_THROWS_WITH_AS(write_medit(tmp("bad.mesh"), t), doctest::Contains("above 999"), Error);
  std::ofstream(tmp("short.ply"), std::ios::binary) << read_all(tmp("m.ply")).substr(0, 200);
  CHECK_THROWS_AS(read_ply(tmp("short.ply")), Error);
}
