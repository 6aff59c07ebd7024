#pragma once
// Readers for the formats mesh_writers.h writes (PLY binary little-endian, Medit .mesh, VTK .vtu in ASCII), enough
// to check round trips and to read cpmesh's own outputs back. They do not try to read every variant of those formats.
#include <string>

#include "io/mesh.h"

namespace cpmesh::io {

TriangleMesh read_ply(const std::string& path);
TetMesh read_medit(const std::string& path);
TetMesh read_vtu(const std::string& path);  // tets and their materials; triangles stay empty

}  // namespace cpmesh::io
