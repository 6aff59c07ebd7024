#pragma once
// Mesh quality measures (docs/design.md, "Measures of quality"), computed once here for the CLI, the report and the tests.
//  - Triangles: radius ratio 2 r_in / r_circ (1 for equilateral): mean, min, share below 0.5.
//  - Interfaces: manifold (no edge in more than two of its triangles) and bounded by triple curves (an edge in only
//    one of its triangles has both ends on a triple curve or quadruple point).
//  - Materials: closed (every edge of the material's boundary triangles is used an even number of times).
//  - Tets: dihedral angles (min, max) and radius-edge ratio (circumradius / shortest edge).
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace cpmesh::io {
struct Junctions;
}

namespace cpmesh::mesh {

double radius_ratio(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c);
// The six dihedral angles of a tet, radians.
std::array<double, 6> dihedral_angles(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d);
// The smallest and largest of them (the same values), with two arc cosines instead of six.
std::array<double, 2> dihedral_range(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d);
// The smallest alone (the same value), with one arc cosine: what the sliver passes test, millions of times.
double min_dihedral(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d);
// The same of tet t over points P.
inline double min_dihedral(const std::vector<glm::dvec3>& P, const std::array<uint32_t, 4>& t) {
  return min_dihedral(P[t[0]], P[t[1]], P[t[2]], P[t[3]]);
}
// The cosine that min_dihedral takes its arc cosine of (the angle is dihedral_from_cosine of it, and never shrinks as
// it grows; neighbouring cosines often give one angle): a tet's smallest dihedral angle for comparisons in inner loops,
// with no arc cosine.
double min_dihedral_cosine(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d);
inline double min_dihedral_cosine(const std::vector<glm::dvec3>& P, const std::array<uint32_t, 4>& t) {
  return min_dihedral_cosine(P[t[0]], P[t[1]], P[t[2]], P[t[3]]);
}
// min_dihedral_cosine where it may be at most `bound`; where it is certainly above `bound`, +infinity. Tested with no
// square root or division first (where the tet's edges lie between about 1e-37 and 1e37; else the exact value), so
// the smallest cosine of many tets, or whether one is at most a bound, costs less with the same answer.
double min_dihedral_cosine_unless_above(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c,
                                        const glm::dvec3& d, double bound);
// The dihedral angle (radians) whose faces' outward normals meet at this cosine: min_dihedral is this of
// min_dihedral_cosine, bit for bit.
inline double dihedral_from_cosine(double cosine) { return M_PI - std::acos(cosine); }
double radius_edge_ratio(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d);
// radius_edge_ratio(a, b, c, d) > limit, the same answer, with no square root where the squares settle it (a limit
// >= 0, squares in the normal range).
bool radius_edge_above(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d,
                       double limit);
// Six times the signed volume of tet abcd: positive where d lies on the side of abc that (b - a) x (c - a) points to.
inline double signed_volume6(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d) {
  return glm::dot(b - a, glm::cross(c - a, d - a));
}
inline double signed_volume6(const std::vector<glm::dvec3>& P, const std::array<uint32_t, 4>& t) {
  return signed_volume6(P[t[0]], P[t[1]], P[t[2]], P[t[3]]);
}
// The volume of tet abcd (unsigned).
inline double tet_volume(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d) {
  return std::fabs(signed_volume6(a, b, c, d)) / 6.0;
}

// Triangle t's normal over points P, twice its area long, by its vertex order (b - a) x (c - a).
inline glm::dvec3 triangle_normal(const std::vector<glm::dvec3>& P, const std::array<uint32_t, 3>& t) {
  return glm::cross(P[t[1]] - P[t[0]], P[t[2]] - P[t[0]]);
}

struct TriangleStats {
  size_t triangles = 0;
  double mean_radius_ratio = 0, min_radius_ratio = 0, share_below_half = 0;
};
TriangleStats triangle_stats(const std::vector<glm::dvec3>& vertices, const std::vector<std::array<uint32_t, 3>>& triangles);
// The radius ratios' sums of groups of triangles; += of two groups gives their union's (to rounding: the sums are
// added in another order than one loop over the union would).
struct TriangleSums {
  size_t triangles = 0, below_half = 0;
  double sum = 0, min = 1;
  TriangleSums& operator+=(const TriangleSums& o);
  TriangleStats stats() const;
};
// Per group (group[t] < groups; every triangle in group 0 where `group` is empty), on every core in fixed chunks
// joined in order: the same sums on any thread count. triangle_stats is its one group.
std::vector<TriangleSums> triangle_sums_by_group(const std::vector<glm::dvec3>& vertices,
                                                 const std::vector<std::array<uint32_t, 3>>& triangles,
                                                 const std::vector<uint32_t>& group, size_t groups);

struct SurfaceCheck {
  size_t nonmanifold_edges = 0;  // in more than two triangles
  size_t boundary_edges = 0;     // in exactly one triangle
  size_t open_edges = 0;         // boundary edges not on a triple curve (vertex kinds 0/1 at both ends)
  bool manifold() const { return nonmanifold_edges == 0 && open_edges == 0; }
};
// vertex_on_curve[v]: the vertex is a triple-curve or quadruple-point particle.
SurfaceCheck check_surface(const std::vector<std::array<uint32_t, 3>>& triangles, const std::vector<uint8_t>& vertex_on_curve);
// check_surface of every interface and odd_edges of every material's boundary from one sort of all the edges:
// interface g is the triangles with group[t] == g, separating materials pair_of[g]; material m's boundary is the
// triangles of the interfaces that have m.
struct EdgeChecks {
  std::vector<SurfaceCheck> interfaces;  // per group
  std::vector<size_t> odd_edges;         // per material
};
EdgeChecks check_edges(const std::vector<std::array<uint32_t, 3>>& triangles, const std::vector<uint32_t>& group,
                       const std::vector<std::array<uint16_t, 2>>& pair_of, size_t materials,
                       const std::vector<uint8_t>& vertex_on_curve);
// Triple-curve edges of a set of interface meshes: edges in triangles of three material pairs or more that
// together span exactly three materials (pair[t] = the two materials triangle t separates). Works on any mesher's
// output, ours or a peer's, since it needs no vertex tags.
struct CurveEdge {
  uint32_t a = 0, b = 0;                  // a < b
  std::array<uint16_t, 3> materials{};    // ascending
};
std::vector<CurveEdge> triple_curve_edges(const std::vector<std::array<uint32_t, 3>>& triangles,
                                          const std::vector<std::array<uint16_t, 2>>& pair);
// Junction error of interface meshes (any mesher's) against analytic triple curves (io::Junctions, the synthetic
// volumes'): the triple-curve edges' midpoints' distance to the curve of the same three materials (mean, max) and
// the largest distance of any point of an edge (its ends and 7 points between them), where the ends' own errors
// (curve vertices, quadruple points) show; in units of `unit` (a voxel). With `on_curve` (one flag per vertex: a
// triple-curve or quadruple-point particle), edges with an end off the curves are left out.
struct JunctionError {
  size_t edges = 0;
  size_t spurious = 0;  // triple edges between three materials that have no curve in common
  double mean = 0, max = 0;
  double max_whole_edge = 0;
};
JunctionError junction_error(const io::Junctions& junctions, const std::vector<std::array<double, 3>>& vertices,
                             const std::vector<std::array<uint32_t, 3>>& triangles,
                             const std::vector<std::array<uint16_t, 2>>& pair, double unit,
                             const std::vector<uint8_t>* on_curve = nullptr);
// Pairs of triangles (t < u) that cross each other anywhere but at the vertices and edges they share: the interface
// meshes must not, or no volume mesher can fill them (TetGen stops on "a segment and a subface intersect").
// Two triangles that are not coplanar intersect exactly when an edge of one crosses the other; triangles sharing a
// vertex can only cross along their edges opposite it, and triangles sharing an edge are left to the flip checks.
// Strict sign tests in double precision: touching counts as not crossing. With `only` (one flag per triangle), only
// pairs with at least one flagged triangle are tested. Triangles go into the cubic cells of a dense grid over their
// bounding box (twice the median edge length, wider where that would make over two cells per triangle), each into
// every cell its bounding box meets, by a parallel counting sort; a pair whose boxes meet is tested once, in the cell
// of their overlap's lowest corner. Measured on a 3.33 M-triangle sphere (2 cores): 1.4-1.7 s, against 3.1 s with
// hashed cells filled by one thread, which bounded the smoothing at scale. (The smoothing calls it every round.)
std::vector<std::array<uint32_t, 2>> crossing_triangles(const std::vector<glm::dvec3>& vertices,
                                                        const std::vector<std::array<uint32_t, 3>>& triangles,
                                                        const std::vector<uint8_t>* only = nullptr);
// Edges of the triangles used an odd number of times (0: closed).
size_t odd_edges(const std::vector<std::array<uint32_t, 3>>& triangles);

// Where the tets' materials and the interface triangles disagree: tet faces between two materials (or between a
// material and the outside, material 0, which has no tets) that are no interface triangle of that pair, and interface
// triangles that are no such face or have another pair. `first` is the centroid of the first one in face order.
// Sorts every tet face once (parallel); the conformity the guarantee assumes and no stage checks on its own.
struct FaceConformity {
  size_t mismatches = 0;
  glm::dvec3 first{0.0};
};
FaceConformity nonconforming_faces(const std::vector<glm::dvec3>& points, const std::vector<std::array<uint32_t, 4>>& tets,
                                   const std::vector<uint16_t>& material,
                                   const std::vector<std::array<uint32_t, 3>>& triangles,
                                   const std::vector<std::array<uint16_t, 2>>& pair);

struct TetStats {
  size_t tets = 0;
  double min_dihedral_deg = 0, max_dihedral_deg = 0, max_radius_edge = 0, mean_radius_edge = 0;
  // The tet with the smallest dihedral angle (the first in the given order where several share it) and its
  // centroid, so that a report can say where the worst element is; SIZE_MAX with no tet.
  size_t worst_tet = SIZE_MAX;
  glm::dvec3 worst_centroid{0.0};
};
TetStats tet_stats(const std::vector<glm::dvec3>& vertices, const std::vector<std::array<uint32_t, 4>>& tets);
// How many tets have a dihedral angle below min_deg degrees (in parallel).
size_t count_below_dihedral(const std::vector<glm::dvec3>& vertices, const std::vector<std::array<uint32_t, 4>>& tets,
                            double min_deg);
// The same per group of tets (group[i] < groups: tet i's group), in one parallel pass; a group with no tet gets
// TetStats{}. `combined` joins groups into the stats of all their tets (worst_tet: the first of the parts' worst with
// the smallest angle, so the same as one group's).
std::vector<TetStats> tet_stats_by_group(const std::vector<glm::dvec3>& vertices,
                                         const std::vector<std::array<uint32_t, 4>>& tets,
                                         const std::vector<uint16_t>& group, size_t groups);
TetStats combined(const std::vector<TetStats>& parts);

}  // namespace cpmesh::mesh
