#pragma once
// The meshes cpmesh outputs, in physical units.
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace cpmesh::io {

// Per-vertex feature of the particle that made the vertex (docs/design.md: quadruple point / triple curve / interface).
enum class VertexFeature : uint8_t { quadruple_point = 0, triple_curve = 1, interface = 2 };

// Interface triangles: triangle t separates materials triangle_pair[t][0] and triangle_pair[t][1].
struct TriangleMesh {
  std::vector<std::array<double, 3>> vertices;
  std::vector<std::array<uint32_t, 3>> triangles;
  std::vector<std::array<uint16_t, 2>> triangle_pair;  // one per triangle (may be empty: then written as 0,0)
  std::vector<uint8_t> vertex_feature;                 // one per vertex, a VertexFeature (may be empty: interface)
  // Extra per-vertex values (sizing, energy, feature id, ...), written by the VTP writer as named arrays.
  std::vector<std::pair<std::string, std::vector<float>>> vertex_scalars;
};

// Tetrahedra with a material each, plus the boundary/interface triangles with their material pairs.
struct TetMesh {
  std::vector<std::array<double, 3>> vertices;
  std::vector<std::array<uint32_t, 4>> tets;
  std::vector<uint16_t> tet_material;  // one per tet
  std::vector<std::array<uint32_t, 3>> triangles;
  std::vector<std::array<uint16_t, 2>> triangle_pair;  // one per triangle
};

}  // namespace cpmesh::io
