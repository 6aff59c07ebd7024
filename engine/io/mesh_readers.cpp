#include "io/mesh_readers.h"

#include <cstring>
#include <fstream>
#include <sstream>

#include "io/error.h"
#include "io/header_text.h"

namespace cpmesh::io {

namespace {

std::string slurp(const std::string& path) {
  check_regular_file(path, "mesh");
  return read_file_range(path, 0, UINT64_MAX);
}

template <typename T>
T take(const std::string& path, const std::string& bytes, size_t& pos) {
  if (pos + sizeof(T) > bytes.size()) fail(path, "field 'data': truncated binary data");
  T v;
  std::memcpy(&v, bytes.data() + pos, sizeof(T));
  pos += sizeof(T);
  return v;
}

uint32_t index_from(const std::string& path, const std::string& field, int64_t one_based, size_t vertices) {
  if (one_based < 1 || uint64_t(one_based) > vertices)
    fail_field(path, field, "vertex indices in 1.." + std::to_string(vertices), std::to_string(one_based));
  return uint32_t(one_based - 1);
}

// The text between <DataArray ... Name="name" ...> and </DataArray>.
std::string vtk_array_text(const std::string& path, const std::string& xml, const std::string& name) {
  const size_t at = xml.find("Name=\"" + name + "\"");
  if (at == std::string::npos) fail_field(path, name, "a DataArray with this name", "");
  const size_t open_end = xml.find('>', at), close = xml.find("</DataArray>", at);
  if (open_end == std::string::npos || close == std::string::npos) fail_field(path, name, "an ascii DataArray", "");
  if (xml.substr(at, open_end - at).find("format=\"ascii\"") == std::string::npos)
    fail_field(path, name, "format=\"ascii\"", "another format");
  return xml.substr(open_end + 1, close - open_end - 1);
}

}  // namespace

TriangleMesh read_ply(const std::string& path) {
  const std::string bytes = slurp(path);
  const size_t end = bytes.find("end_header\n");
  if (bytes.rfind("ply\n", 0) != 0 || end == std::string::npos) fail_field(path, "header", "a PLY header", bytes.substr(0, 20));
  const std::string header = bytes.substr(0, end);
  if (header.find("format binary_little_endian 1.0") == std::string::npos)
    fail_field(path, "format", "binary_little_endian 1.0 (cpmesh's own layout)", "");
  const std::string expected_vertex = "property float x\nproperty float y\nproperty float z\nproperty uchar feature\n";
  const std::string expected_face =
      "property list uchar uint vertex_indices\nproperty ushort material_a\nproperty ushort material_b\n";
  if (header.find(expected_vertex) == std::string::npos || header.find(expected_face) == std::string::npos)
    fail_field(path, "properties", "cpmesh's vertex and face properties", "");
  auto count = [&](const std::string& element) {
    const size_t at = header.find("element " + element + " ");
    if (at == std::string::npos) fail_field(path, "element " + element, "a count", "");
    return uint64_t(parse_int(path, "element " + element, header.substr(at + 9 + element.size(),
                                                                         header.find('\n', at) - at - 9 - element.size())));
  };
  const uint64_t nv = count("vertex"), nf = count("face");
  if (nv * 13 + nf * 17 != bytes.size() - end - 11)
    fail_field(path, "element counts", std::to_string(nv * 13 + nf * 17) + " bytes of data",
               std::to_string(bytes.size() - end - 11));
  TriangleMesh m;
  size_t pos = end + 11;
  for (uint64_t v = 0; v < nv; ++v) {
    std::array<double, 3> p;
    for (double& x : p) x = take<float>(path, bytes, pos);
    m.vertices.push_back(p);
    m.vertex_feature.push_back(take<uint8_t>(path, bytes, pos));
  }
  for (uint64_t f = 0; f < nf; ++f) {
    if (take<uint8_t>(path, bytes, pos) != 3) fail_field(path, "vertex_indices", "triangles", "another polygon");
    std::array<uint32_t, 3> t;
    for (uint32_t& i : t) {
      i = take<uint32_t>(path, bytes, pos);
      if (i >= nv) fail_field(path, "vertex_indices", "indices below " + std::to_string(nv), std::to_string(i));
    }
    m.triangles.push_back(t);
    const uint16_t a = take<uint16_t>(path, bytes, pos), b = take<uint16_t>(path, bytes, pos);
    m.triangle_pair.push_back({a, b});
  }
  return m;
}

TetMesh read_medit(const std::string& path) {
  std::istringstream in(slurp(path));
  TetMesh m;
  std::string word;
  auto read_count = [&](const std::string& field) {
    int64_t n = -1;
    if (!(in >> n) || n < 0) fail_field(path, field, "a count", "");
    return size_t(n);
  };
  auto read_int = [&](const std::string& field) {
    int64_t x;
    if (!(in >> x)) fail_field(path, field, "an integer", "");
    return x;
  };
  while (in >> word) {
    if (word[0] == '#') {
      std::getline(in, word);
    } else if (word == "MeshVersionFormatted" || word == "Dimension") {
      read_int(word);
    } else if (word == "Vertices") {
      const size_t n = read_count(word);
      for (size_t v = 0; v < n; ++v) {
        std::array<double, 3> p;
        if (!(in >> p[0] >> p[1] >> p[2])) fail_field(path, "Vertices", "x y z ref lines", "");
        read_int("Vertices");
        m.vertices.push_back(p);
      }
    } else if (word == "Triangles") {
      const size_t n = read_count(word);
      for (size_t t = 0; t < n; ++t) {
        std::array<uint32_t, 3> tri;
        for (uint32_t& i : tri) i = index_from(path, "Triangles", read_int("Triangles"), m.vertices.size());
        const int64_t ref = read_int("Triangles");
        m.triangles.push_back(tri);
        m.triangle_pair.push_back({uint16_t(ref / 1000), uint16_t(ref % 1000)});
      }
    } else if (word == "Tetrahedra") {
      const size_t n = read_count(word);
      for (size_t t = 0; t < n; ++t) {
        std::array<uint32_t, 4> tet;
        for (uint32_t& i : tet) i = index_from(path, "Tetrahedra", read_int("Tetrahedra"), m.vertices.size());
        m.tets.push_back(tet);
        m.tet_material.push_back(uint16_t(read_int("Tetrahedra")));
      }
    } else if (word == "End") {
      break;
    } else {
      fail_field(path, "keyword", "MeshVersionFormatted, Dimension, Vertices, Triangles, Tetrahedra or End", word);
    }
  }
  return m;
}

TetMesh read_vtu(const std::string& path) {
  const std::string xml = slurp(path);
  TetMesh m;
  std::istringstream points(vtk_array_text(path, xml, "Points"));
  for (std::array<double, 3> p; points >> p[0] >> p[1] >> p[2];) m.vertices.push_back(p);
  std::istringstream conn(vtk_array_text(path, xml, "connectivity"));
  for (std::array<int64_t, 4> t; conn >> t[0] >> t[1] >> t[2] >> t[3];) {
    std::array<uint32_t, 4> tet;
    for (int i = 0; i < 4; ++i) tet[i] = index_from(path, "connectivity", t[i] + 1, m.vertices.size());
    m.tets.push_back(tet);
  }
  std::istringstream mat(vtk_array_text(path, xml, "material"));
  for (int64_t l; mat >> l;) m.tet_material.push_back(uint16_t(l));
  if (m.tet_material.size() != m.tets.size())
    fail_field(path, "material", std::to_string(m.tets.size()) + " values", std::to_string(m.tet_material.size()));
  return m;
}

}  // namespace cpmesh::io
