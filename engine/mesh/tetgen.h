#pragma once
// TetGen (Si 2015, library calls, never a subprocess), behind a small interface: tetgen.h defines macros that must
// not leak, so only tetgen.cpp includes it.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::mesh {

struct Tets {
  std::vector<glm::dvec3> points;              // may grow (Steiner points) in a constrained mesh
  std::vector<std::array<uint32_t, 4>> tets;
  std::vector<int> region;                      // per tet: region attribute (constrained meshes), else empty
  std::vector<std::array<uint32_t, 3>> faces;   // boundary/interface faces kept (constrained meshes)
  std::vector<int> face_marker;                 // per face: the input facet marker
  std::vector<int32_t> neighbours;              // delaunay(): 4 per tet, the tets across its faces (-1: hull), in
                                                // TetGen's order; else empty
};

// Delaunay tetrahedralization of a point set (TetGen "Qzn", with the tets' neighbours). Of points at exactly the
// same place only one is meshed (the first TetGen meets in its own random order); every output index refers to the
// input points. parallel_delaunay (delaunay.h) does the same on every core.
Tets delaunay(const std::vector<glm::dvec3>& points);

// TetGen's exact predicates (Shewchuk's adaptive ones): orient3d's sign tells on which side of plane abc d lies (0: on
// it); insphere is positive where e lies inside the sphere through abcd when orient3d(a, b, c, d) is positive,
// negative inside when it is negative. Exact for any finite points and safe on any thread: TetGen keeps its
// predicates' settings in process-wide variables, which this file sets once, without TetGen's static filters (they
// hold one point set's bounding box), and sets back after each TetGen run in this process (TetGen sets them for its
// own points; such runs happen only in child processes and tests, never beside other users).
double orient3d_exact(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d);
double insphere_exact(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d,
                      const glm::dvec3& e);
// The same, first answered in floating point where TetGen's static filters (its error bounds for points whose
// coordinates differ by at most `extent` per axis: their bounding box's size) allow, as TetGen answers its own
// tests; the rest exactly as above. Each instance holds its own bounds: instances for different points may be used
// at once. The extent is widened so that no axis is under a thousandth of the largest (a larger bound is only more
// careful).
class FilteredPredicates {
 public:
  explicit FilteredPredicates(const glm::dvec3& extent = glm::dvec3(1.0));
  const glm::dvec3& extent() const { return extent_; }
  double orient3d(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d) const;
  double insphere(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d,
                  const glm::dvec3& e) const;

 private:
  glm::dvec3 extent_;
  double orient_bound_, insphere_bound_;
};
// The corners of the points' bounding box (lo, hi); points must not be empty.
std::array<glm::dvec3, 2> bounding_box(const std::vector<glm::dvec3>& points);

struct QualityOptions {
  double max_radius_edge = 1.5;  // TetGen -q ratio
  double min_dihedral = 12.0;    // degrees: the bound the sliver passes hold (volume_mesh.h)
  // Whether TetGen refines to min_dihedral too (-q's second value). Off for the materials: TetGen's refinement then
  // stops at the radius-edge bound and the sliver passes mend the slivers it leaves. Material 1 of the paper-size
  // head on one core: TetGen 105.0 s, 6.26 M tets, passes 5.1 s with it; 73.7 s, 4.80 M tets, passes 14.0 s without.
  // On for the cavities remesh_slivers meshes afresh, where TetGen's own refinement is the mend.
  bool dihedral_in_tetgen = false;
  double max_volume = 0;         // TetGen -a (0: no limit)
  // How far the last sliver pass (surface_slivers.h) may move an interface or curve vertex off its feature, in voxels
  // (of the smallest spacing); 0 keeps every vertex on its feature. The voxels place an interface to about a voxel.
  double sliver_offset = 0.2;
  // Interface triangles under this radius ratio have their vertices moved by the same pass, against the same tets
  // (surface_slivers.h); 0: off.
  double min_triangle_ratio = 0.3;
  bool keep_surface = true;      // TetGen -Y: no Steiner points on the input triangles
  // mesh_materials only: TetGen starts from interior_points (interior_points.h) as well as the surface vertices. On
  // the paper-size head's surfaces, one core: material 4 27.9 -> 14.5 s, material 1 74.3 -> 54.9 s, the same tets
  // within 1%.
  bool interior_points = true;
  // mesh_materials only (volume_mesh.h): how many TetGen runs to aim at, large materials cut into pieces
  // (split_material.h) so that the runs fill the cores; 0: the thread limit (tbb::global_control, --threads). 1, the
  // default, is one run per material: the mesh then does not depend on the machine's cores, and on few cores the
  // cut and the seams cost more than the parallel runs win. Pieces leave about as few slivers (the paper-size head in
  // 16 pieces: 2-3 tets under 12 degrees, from 11.0, against none whole), so many-core hosts should ask for them.
  size_t runs = 1;
  size_t min_piece_triangles = 20'000;  // a material is cut only into pieces of at least this many boundary triangles
                                        // on average (a piece whose plane moved keeps at least 3/4 of its share)
};

struct Region {
  glm::dvec3 seed;  // a point inside the region
  int attribute;
};

// Quality constrained tetrahedralization of the closed triangle surfaces `triangles` over `points` (TetGen "pqAY",
// the dihedral bound after q where options.dihedral_in_tetgen), each region labelled by the attribute of the seed
// inside it; space outside every closed surface is not meshed, nor is the region around each point of `holes`.
// `interior` are more points for TetGen to start from (interior_points.h); those outside the meshed regions go.
// Markers are carried to the output faces. Runs in a child process (child_process.h). Throws std::runtime_error with
// TetGen's reason on failure.
// Output numbering: `points` first, unchanged (those no triangle uses are in no tet), then the points TetGen added
// and the interior points it kept, in its order.
Tets constrained_quality(const std::vector<glm::dvec3>& points, const std::vector<std::array<uint32_t, 3>>& triangles,
                         const std::vector<int>& markers, const std::vector<Region>& regions,
                         const QualityOptions& options, const std::vector<glm::dvec3>& holes = {},
                         const std::vector<glm::dvec3>& interior = {});
// The same in this process, for a job that already runs in a child (a failing TetGen can kill its process).
Tets constrained_quality_in_this_process(const std::vector<glm::dvec3>& points,
                                         const std::vector<std::array<uint32_t, 3>>& triangles,
                                         const std::vector<int>& markers, const std::vector<Region>& regions,
                                         const QualityOptions& options, const std::vector<glm::dvec3>& holes = {},
                                         const std::vector<glm::dvec3>& interior = {});

// Throws std::invalid_argument for bounds TetGen's refinement is not known to meet.
void check_quality_options(const QualityOptions& options);

// Tets as bytes, to come back from a child process.
class ByteWriter;
class ByteReader;
void put_tets(ByteWriter& w, const Tets& t);
bool get_tets(ByteReader& r, Tets& t);  // false: the bytes ended early

}  // namespace cpmesh::mesh
