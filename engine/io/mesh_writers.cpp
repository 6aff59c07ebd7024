#include "io/mesh_writers.h"

#include <charconv>
#include <cmath>
#include <cstring>
#include <map>
#include <ostream>
#include <string>
#include <type_traits>

#include <tbb/parallel_for.h>

#include "io/atomic_file.h"
#include "io/error.h"
#include "io/header_text.h"
#include "io/scalar_type.h"

namespace cpmesh::io {

namespace {

template <size_t N>
void check_indices(const std::vector<std::array<uint32_t, N>>& cells, size_t vertices, const std::string& path,
                   const char* what) {
  for (size_t c = 0; c < cells.size(); ++c)
    for (uint32_t v : cells[c])
      if (v >= vertices)
        fail(path, std::string("cannot write: ") + what + " " + std::to_string(c) + " uses vertex " + std::to_string(v) +
                       " of " + std::to_string(vertices));
}

void check(const TriangleMesh& m, const std::string& path) {
  check_indices(m.triangles, m.vertices.size(), path, "triangle");
  if (!m.triangle_pair.empty() && m.triangle_pair.size() != m.triangles.size())
    fail(path, "cannot write: " + std::to_string(m.triangle_pair.size()) + " material pairs for " +
                   std::to_string(m.triangles.size()) + " triangles");
  if (!m.vertex_feature.empty() && m.vertex_feature.size() != m.vertices.size())
    fail(path, "cannot write: " + std::to_string(m.vertex_feature.size()) + " vertex features for " +
                   std::to_string(m.vertices.size()) + " vertices");
}

void check(const TetMesh& m, const std::string& path) {
  check_indices(m.tets, m.vertices.size(), path, "tet");
  check_indices(m.triangles, m.vertices.size(), path, "triangle");
  if (m.tet_material.size() != m.tets.size())
    fail(path, "cannot write: " + std::to_string(m.tet_material.size()) + " materials for " +
                   std::to_string(m.tets.size()) + " tets");
  if (m.triangle_pair.size() != m.triangles.size())
    fail(path, "cannot write: " + std::to_string(m.triangle_pair.size()) + " material pairs for " +
                   std::to_string(m.triangles.size()) + " triangles");
}

std::array<uint16_t, 2> pair_of(const TriangleMesh& m, size_t t) {
  return m.triangle_pair.empty() ? std::array<uint16_t, 2>{0, 0} : m.triangle_pair[t];
}
uint8_t feature_of(const TriangleMesh& m, size_t v) {
  return m.vertex_feature.empty() ? uint8_t(VertexFeature::interface) : m.vertex_feature[v];
}

template <typename T>
void put(std::ostream& out, T v) {  // little-endian hosts only (checked in write_ply/write_stl)
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.write(b, sizeof(T));
}

void require_little_endian_host(const std::string& path) {
  if (host_is_big_endian()) fail(path, "binary mesh writers support little-endian hosts only");
}

std::array<double, 3> normal_of(const TriangleMesh& m, const std::array<uint32_t, 3>& t) {
  const auto &a = m.vertices[t[0]], &b = m.vertices[t[1]], &c = m.vertices[t[2]];
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  std::array<double, 3> n = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
  const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  if (len > 0)
    for (double& x : n) x /= len;
  return n;
}

// Text output of numbers by std::to_chars: integers, and floating-point values in the shortest form that reads back
// to the same value (what setprecision(17) guaranteed, in fewer characters).
class Text {
 public:
  explicit Text(std::string& s) : s_(s) {}
  Text& operator<<(char c) {
    s_.push_back(c);
    return *this;
  }
  Text& operator<<(const char* c) {
    s_.append(c);
    return *this;
  }
  template <typename T>
    requires std::is_arithmetic_v<T>
  Text& operator<<(T v) {
    char b[32];
    const auto r = sizeof(T) == 1 ? std::to_chars(b, b + sizeof b, unsigned(v)) : std::to_chars(b, b + sizeof b, v);
    s_.append(b, r.ptr);
    return *this;
  }

 private:
  std::string& s_;
};

// Lines for items 0..n-1: line(text, i) formats item i. Chunks of items are formatted in parallel and written in
// order, a batch at a time (a text writer printing one number at a time through the stream took 6.6 s for a
// million points and five million tets here; meshes of twenty million tets are written at the paper's density).
template <typename F>
void write_lines(std::ostream& out, size_t n, F&& line) {
  constexpr size_t kChunk = 8192, kBatch = 64;
  std::vector<std::string> text;
  for (size_t first = 0; first < n; first += kChunk * kBatch) {
    const size_t chunks = std::min(kBatch, (n - first + kChunk - 1) / kChunk);
    text.assign(chunks, std::string());
    tbb::parallel_for(size_t(0), chunks, [&](size_t c) {
      Text t(text[c]);
      const size_t lo = first + c * kChunk, hi = std::min(n, lo + kChunk);
      for (size_t i = lo; i < hi; ++i) line(t, i);
    });
    for (const auto& s : text) out.write(s.data(), std::streamsize(s.size()));
  }
}

// Ascii arrays of VTK XML files: each(text, i) writes item i's components.
template <typename F>
void vtk_array(std::ostream& out, const char* type, const char* name, int components, size_t n, F each) {
  out << "        <DataArray type=\"" << type << "\"" << (name ? std::string(" Name=\"") + name + "\"" : "")
      << " NumberOfComponents=\"" << components << "\" format=\"ascii\">\n";
  write_lines(out, n, [&](Text& t, size_t i) {
    t << "         ";
    each(t, i);
    t << '\n';
  });
  out << "        </DataArray>\n";
}

void vtk_points(std::ostream& out, const std::vector<std::array<double, 3>>& vertices) {
  out << "      <Points>\n";
  vtk_array(out, "Float64", "Points", 3, vertices.size(), [&](Text& t, size_t v) {
    const auto& p = vertices[v];
    t << p[0] << ' ' << p[1] << ' ' << p[2];
  });
  out << "      </Points>\n";
}

template <size_t N>
void vtk_cells(std::ostream& out, const std::vector<std::array<uint32_t, N>>& cells) {
  vtk_array(out, "Int64", "connectivity", 1, cells.size(), [&](Text& t, size_t c) {
    for (size_t i = 0; i < N; ++i) {
      t << cells[c][i];
      if (i + 1 < N) t << ' ';
    }
  });
  vtk_array(out, "Int64", "offsets", 1, cells.size(), [&](Text& t, size_t c) { t << uint64_t((c + 1) * N); });
}

}  // namespace

int32_t pair_reference(const std::array<uint16_t, 2>& pair, const std::string& path) {
  const int a = std::min(pair[0], pair[1]), b = std::max(pair[0], pair[1]);
  if (b > 999) fail(path, "material " + std::to_string(b) + " is above 999: the pair reference 1000*a+b would be ambiguous");
  return a * 1000 + b;
}

void write_ply(const std::string& path, const TriangleMesh& m) {
  check(m, path);
  require_little_endian_host(path);
  write_atomically(path, [&](std::ostream& out) {
    out << "ply\nformat binary_little_endian 1.0\ncomment cpmesh interface mesh: material_a/material_b per face, "
           "feature per vertex (0 quadruple point, 1 triple curve, 2 interface)\nelement vertex "
        << m.vertices.size() << "\nproperty float x\nproperty float y\nproperty float z\nproperty uchar feature\n"
        << "element face " << m.triangles.size()
        << "\nproperty list uchar uint vertex_indices\nproperty ushort material_a\nproperty ushort material_b\n"
        << "end_header\n";
    for (size_t v = 0; v < m.vertices.size(); ++v) {
      for (double x : m.vertices[v]) put(out, float(x));
      put(out, feature_of(m, v));
    }
    for (size_t t = 0; t < m.triangles.size(); ++t) {
      put(out, uint8_t(3));
      for (uint32_t i : m.triangles[t]) put(out, i);
      for (uint16_t l : pair_of(m, t)) put(out, l);
    }
  });
}

void write_obj(const std::string& path, const TriangleMesh& m) {
  check(m, path);
  // Group triangles by pair so each interface is one object in viewers.
  std::map<std::array<uint16_t, 2>, std::vector<size_t>> groups;
  for (size_t t = 0; t < m.triangles.size(); ++t) groups[pair_of(m, t)].push_back(t);
  write_atomically(path, [&](std::ostream& out) {
    out << "# cpmesh interface mesh: one group per material pair\n";
    write_lines(out, m.vertices.size(), [&](Text& t, size_t v) {
      const auto& p = m.vertices[v];
      t << "v " << p[0] << ' ' << p[1] << ' ' << p[2] << '\n';
    });
    for (const auto& [pair, tris] : groups) {
      out << "g interface_" << pair[0] << '_' << pair[1] << '\n';
      write_lines(out, tris.size(), [&](Text& t, size_t k) {
        const auto& tri = m.triangles[tris[k]];
        t << "f " << tri[0] + 1 << ' ' << tri[1] + 1 << ' ' << tri[2] + 1 << '\n';
      });
    }
  });
}

void write_stl(const std::string& path, const TriangleMesh& m) {
  check(m, path);
  require_little_endian_host(path);
  if (m.triangles.size() > UINT32_MAX) fail(path, "too many triangles for STL");
  write_atomically(path, [&](std::ostream& out) {
    std::string header = "cpmesh interface mesh (binary STL)";
    header.resize(80, ' ');
    out << header;
    put(out, uint32_t(m.triangles.size()));
    for (const auto& t : m.triangles) {
      for (double x : normal_of(m, t)) put(out, float(x));
      for (uint32_t v : t)
        for (double x : m.vertices[v]) put(out, float(x));
      put(out, uint16_t(0));
    }
  });
}

void write_vtp(const std::string& path, const TriangleMesh& m) {
  check(m, path);
  write_atomically(path, [&](std::ostream& out) {
    out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" "
           "header_type=\"UInt64\">\n  <PolyData>\n    <Piece NumberOfPoints=\""
        << m.vertices.size() << "\" NumberOfPolys=\"" << m.triangles.size() << "\">\n";
    vtk_points(out, m.vertices);
    out << "      <Polys>\n";
    vtk_cells(out, m.triangles);
    out << "      </Polys>\n      <CellData Scalars=\"material_pair\">\n";
    vtk_array(out, "UInt16", "material_pair", 2, m.triangles.size(), [&](Text& t, size_t c) {
      const auto p = pair_of(m, c);
      t << p[0] << ' ' << p[1];
    });
    out << "      </CellData>\n      <PointData Scalars=\"feature\">\n";
    vtk_array(out, "UInt8", "feature", 1, m.vertices.size(), [&](Text& t, size_t v) { t << feature_of(m, v); });
    for (const auto& [name, values] : m.vertex_scalars) {
      if (values.size() != m.vertices.size())
        fail(path, "vertex array '" + name + "' has " + std::to_string(values.size()) + " values for " +
                       std::to_string(m.vertices.size()) + " vertices");
      vtk_array(out, "Float32", name.c_str(), 1, values.size(), [&](Text& t, size_t v) { t << values[v]; });
    }
    out << "      </PointData>\n    </Piece>\n  </PolyData>\n</VTKFile>\n";
  });
}

void write_triangle_mesh(const std::string& path, const TriangleMesh& m) {
  const std::string p = to_lower(path);
  if (ends_with(p, ".ply")) return write_ply(path, m);
  if (ends_with(p, ".obj")) return write_obj(path, m);
  if (ends_with(p, ".stl")) return write_stl(path, m);
  if (ends_with(p, ".vtp")) return write_vtp(path, m);
  fail(path, "unknown triangle mesh extension (expected .ply, .obj, .stl or .vtp)");
}

void write_medit(const std::string& path, const TetMesh& m) {
  check(m, path);
  std::vector<int32_t> refs;
  for (const auto& p : m.triangle_pair) refs.push_back(pair_reference(p, path));
  write_atomically(path, [&](std::ostream& out) {
    out << "MeshVersionFormatted 2\n# cpmesh: triangle reference = 1000 * a + b for "
        << "materials a < b; tetrahedron reference = material\nDimension 3\nVertices\n" << m.vertices.size() << '\n';
    write_lines(out, m.vertices.size(), [&](Text& t, size_t v) {
      const auto& p = m.vertices[v];
      t << p[0] << ' ' << p[1] << ' ' << p[2] << " 0\n";
    });
    out << "Triangles\n" << m.triangles.size() << '\n';
    write_lines(out, m.triangles.size(), [&](Text& t, size_t c) {
      const auto& tri = m.triangles[c];
      t << tri[0] + 1 << ' ' << tri[1] + 1 << ' ' << tri[2] + 1 << ' ' << refs[c] << '\n';
    });
    out << "Tetrahedra\n" << m.tets.size() << '\n';
    write_lines(out, m.tets.size(), [&](Text& t, size_t c) {
      for (uint32_t v : m.tets[c]) t << v + 1 << ' ';
      t << m.tet_material[c] << '\n';
    });
    out << "End\n";
  });
}

void write_vtu(const std::string& path, const TetMesh& m) {
  check(m, path);
  write_atomically(path, [&](std::ostream& out) {
    out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
           "header_type=\"UInt64\">\n  <UnstructuredGrid>\n    <Piece NumberOfPoints=\""
        << m.vertices.size() << "\" NumberOfCells=\"" << m.tets.size() << "\">\n";
    vtk_points(out, m.vertices);
    out << "      <Cells>\n";
    vtk_cells(out, m.tets);
    vtk_array(out, "UInt8", "types", 1, m.tets.size(), [&](Text& t, size_t) { t << 10; });  // VTK_TETRA
    out << "      </Cells>\n      <CellData Scalars=\"material\">\n";
    vtk_array(out, "UInt16", "material", 1, m.tet_material.size(), [&](Text& t, size_t c) { t << m.tet_material[c]; });
    out << "      </CellData>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n";
  });
}

void write_tetgen(const std::string& base, const TetMesh& m) {
  check(m, base + ".node");
  std::vector<int32_t> refs;
  for (const auto& p : m.triangle_pair) refs.push_back(pair_reference(p, base + ".face"));
  write_atomically(base + ".node", [&](std::ostream& out) {
    out << m.vertices.size() << " 3 0 0\n";
    write_lines(out, m.vertices.size(), [&](Text& t, size_t v) {
      const auto& p = m.vertices[v];
      t << v + 1 << ' ' << p[0] << ' ' << p[1] << ' ' << p[2] << '\n';
    });
  });
  write_atomically(base + ".ele", [&](std::ostream& out) {
    out << m.tets.size() << " 4 1\n";
    write_lines(out, m.tets.size(), [&](Text& t, size_t c) {
      t << c + 1;
      for (uint32_t v : m.tets[c]) t << ' ' << v + 1;
      t << ' ' << m.tet_material[c] << '\n';
    });
  });
  write_atomically(base + ".face", [&](std::ostream& out) {
    out << m.triangles.size() << " 1\n";
    write_lines(out, m.triangles.size(), [&](Text& t, size_t c) {
      const auto& tri = m.triangles[c];
      t << c + 1 << ' ' << tri[0] + 1 << ' ' << tri[1] + 1 << ' ' << tri[2] + 1 << ' ' << refs[c] << '\n';
    });
  });
}

}  // namespace cpmesh::io
