#pragma once
// Mesh files for ParaView, MeshLab, Gmsh, FEBio, TetGen users. Every writer checks indices and tag counts first and
// writes through write_atomically.
//
// Triangle meshes: PLY (binary little-endian; face properties material_a/material_b, vertex property feature),
//   OBJ (one group "interface_A_B" per material pair), STL (binary; no tags), VTK XML PolyData .vtp (cell data
//   "material_pair" (2 components), point data "feature").
// Tet meshes: Medit .mesh (triangle reference = 1000 * a + b for the pair a < b, tet reference = material), VTK XML
//   UnstructuredGrid .vtu (cell data "material"), TetGen .node/.ele/.face (1-based; attribute/marker as in .mesh).
#include <string>

#include "io/mesh.h"

namespace cpmesh::io {

void write_ply(const std::string& path, const TriangleMesh& m);
void write_obj(const std::string& path, const TriangleMesh& m);
void write_stl(const std::string& path, const TriangleMesh& m);
void write_vtp(const std::string& path, const TriangleMesh& m);
// By extension: .ply .obj .stl .vtp.
void write_triangle_mesh(const std::string& path, const TriangleMesh& m);

void write_medit(const std::string& path, const TetMesh& m);
void write_vtu(const std::string& path, const TetMesh& m);
// `base` without extension: writes base.node, base.ele, base.face.
void write_tetgen(const std::string& base, const TetMesh& m);

// The Medit/TetGen reference of a material pair; throws when a label is above 999 (the encoding would be ambiguous).
int32_t pair_reference(const std::array<uint16_t, 2>& pair, const std::string& path);

}  // namespace cpmesh::io
