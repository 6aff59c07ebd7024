#include "mesh/tetgen.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <stdexcept>

#include <tetgen.h>

#include "mesh/child_process.h"

namespace cpmesh::mesh {

namespace {

void set_points(tetgenio& in, const std::vector<glm::dvec3>& points) {
  in.firstnumber = 0;
  in.numberofpoints = int(points.size());
  in.pointlist = new REAL[points.size() * 3];
  for (size_t i = 0; i < points.size(); ++i)
    for (int a = 0; a < 3; ++a) in.pointlist[3 * i + size_t(a)] = points[i][a];
}

Tets read_output(const tetgenio& out) {
  Tets t;
  for (int i = 0; i < out.numberofpoints; ++i)
    t.points.push_back({out.pointlist[3 * i], out.pointlist[3 * i + 1], out.pointlist[3 * i + 2]});
  const int corners = out.numberofcorners;
  for (int i = 0; i < out.numberoftetrahedra; ++i) {
    std::array<uint32_t, 4> v;
    for (int a = 0; a < 4; ++a) v[size_t(a)] = uint32_t(out.tetrahedronlist[i * corners + a]);
    t.tets.push_back(v);
    if (out.numberoftetrahedronattributes > 0)
      t.region.push_back(int(out.tetrahedronattributelist[i * out.numberoftetrahedronattributes]));
  }
  if (out.neighborlist) t.neighbours.assign(out.neighborlist, out.neighborlist + size_t(out.numberoftetrahedra) * 4);
  for (int i = 0; i < out.numberoftrifaces; ++i) {
    t.faces.push_back({uint32_t(out.trifacelist[3 * i]), uint32_t(out.trifacelist[3 * i + 1]),
                       uint32_t(out.trifacelist[3 * i + 2])});
    t.face_marker.push_back(out.trifacemarkerlist ? out.trifacemarkerlist[i] : 0);
  }
  return t;
}

// TetGen's predicates without its static filters (exact for any points: tetgen.h), set before main and again
// after each TetGen run in this process.
void unfiltered_predicates() { exactinit(0, 0, 1, 1.0, 1.0, 1.0); }
[[maybe_unused]] const bool predicates_set = (unfiltered_predicates(), true);

void run(const std::string& switches, tetgenio& in, tetgenio& out) {
  std::vector<char> sw(switches.begin(), switches.end());
  sw.push_back('\0');
  struct Restore {
    ~Restore() { unfiltered_predicates(); }
  } restore;  // TetGen set the predicates for its own points
  try {
    tetrahedralize(sw.data(), &in, &out);
  } catch (int code) {
    // TetGen's terminatetetgen codes: 1 out of memory, 2 internal error, 3 self-intersecting input, 4 a very small
    // input feature size, 5 a very close pair of input facets, 10 an input error.
    const char* why = code == 1   ? "out of memory"
                      : code == 3 ? "the input surfaces intersect each other"
                      : code == 4 || code == 5 ? "input features too small or facets too close for the tolerance"
                      : code == 10 ? "invalid input"
                                   : "internal error";
    throw std::runtime_error("TetGen (" + switches + ") failed with code " + std::to_string(code) + ": " + why);
  }
}

}  // namespace

Tets delaunay(const std::vector<glm::dvec3>& points) {
  if (points.size() < 4) throw std::runtime_error("Delaunay tetrahedralization needs at least 4 points, got " + std::to_string(points.size()));
  // TetGen asserts (aborts) when its points' bounding box is flat.
  const auto [lo, hi] = bounding_box(points);
  if (!(hi.x > lo.x && hi.y > lo.y && hi.z > lo.z))
    throw std::runtime_error("Delaunay tetrahedralization: all " + std::to_string(points.size()) +
                             " points lie on one coordinate plane");
  tetgenio in, out;
  set_points(in, points);
  run("Qzn", in, out);
  Tets t = read_output(out);
  // TetGen lists the points it kept, in input order, and drops one that coincides with an earlier one; that shifted
  // every later index (seen on the 64^3 shells: two particles of the one-voxel shell at one float position
  // scrambled the mesh after the second, and its volume mesh never finished recovering the boundary). Each output
  // point is mapped to its input point by walking both lists, so a dropped point is in no tet.
  std::vector<uint32_t> input_at(t.points.size());
  size_t next = 0;
  for (size_t j = 0; j < t.points.size(); ++j) {
    while (next < points.size() && points[next] != t.points[j]) ++next;
    if (next == points.size()) throw std::runtime_error("TetGen (Qz) returned a point that is not in its input");
    input_at[j] = uint32_t(next++);
  }
  for (auto& tet : t.tets)
    for (auto& v : tet) v = input_at[v];
  t.points = points;  // no Steiner points: keep the exact input
  return t;
}

FilteredPredicates::FilteredPredicates(const glm::dvec3& extent) {
  const double largest = std::max({extent.x, extent.y, extent.z, 1e-300});
  extent_ = glm::max(extent, glm::dvec3(largest * 1e-3));
  // TetGen's static filters (exactinit): error bounds of the floating-point determinants below for coordinate
  // differences up to the extent, the largest axis taken twice more for insphere's lifted terms.
  const double product = extent_.x * extent_.y * extent_.z, top = std::max({extent_.x, extent_.y, extent_.z});
  orient_bound_ = 5.1107127829973299e-15 * product;
  insphere_bound_ = 1.2466136531027298e-13 * product * top * top;
}

double FilteredPredicates::orient3d(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c,
                                    const glm::dvec3& d) const {
  // The determinant exactly as TetGen's orient3d evaluates it, which its bound is for.
  const double adx = a.x - d.x, bdx = b.x - d.x, cdx = c.x - d.x;
  const double ady = a.y - d.y, bdy = b.y - d.y, cdy = c.y - d.y;
  const double adz = a.z - d.z, bdz = b.z - d.z, cdz = c.z - d.z;
  const double det = adz * (bdx * cdy - cdx * bdy) + bdz * (cdx * ady - adx * cdy) + cdz * (adx * bdy - bdx * ady);
  if (det > orient_bound_ || det < -orient_bound_) return det;
  return orient3d_exact(a, b, c, d);
}

double FilteredPredicates::insphere(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c,
                                    const glm::dvec3& d, const glm::dvec3& e) const {
  // The determinant exactly as TetGen's insphere evaluates it (Shewchuk's), which its bound is for.
  const double aex = a.x - e.x, bex = b.x - e.x, cex = c.x - e.x, dex = d.x - e.x;
  const double aey = a.y - e.y, bey = b.y - e.y, cey = c.y - e.y, dey = d.y - e.y;
  const double aez = a.z - e.z, bez = b.z - e.z, cez = c.z - e.z, dez = d.z - e.z;
  const double ab = aex * bey - bex * aey, bc = bex * cey - cex * bey, cd = cex * dey - dex * cey;
  const double da = dex * aey - aex * dey, ac = aex * cey - cex * aey, bd = bex * dey - dex * bey;
  const double abc = aez * bc - bez * ac + cez * ab, bcd = bez * cd - cez * bd + dez * bc;
  const double cda = cez * da + dez * ac + aez * cd, dab = dez * ab + aez * bd + bez * da;
  const double alift = aex * aex + aey * aey + aez * aez, blift = bex * bex + bey * bey + bez * bez;
  const double clift = cex * cex + cey * cey + cez * cez, dlift = dex * dex + dey * dey + dez * dez;
  const double det = (dlift * abc - clift * dab) + (blift * cda - alift * bcd);
  if (det > insphere_bound_ || det < -insphere_bound_) return det;
  return insphere_exact(a, b, c, d, e);
}

std::array<glm::dvec3, 2> bounding_box(const std::vector<glm::dvec3>& points) {
  std::array<glm::dvec3, 2> box = {points.at(0), points.at(0)};
  for (const auto& p : points) {
    box[0] = glm::min(box[0], p);
    box[1] = glm::max(box[1], p);
  }
  return box;
}

double orient3d_exact(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d) {
  REAL pa[3] = {a.x, a.y, a.z}, pb[3] = {b.x, b.y, b.z}, pc[3] = {c.x, c.y, c.z}, pd[3] = {d.x, d.y, d.z};
  return orient3d(pa, pb, pc, pd);
}

double insphere_exact(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d,
                      const glm::dvec3& e) {
  REAL pa[3] = {a.x, a.y, a.z}, pb[3] = {b.x, b.y, b.z}, pc[3] = {c.x, c.y, c.z}, pd[3] = {d.x, d.y, d.z},
       pe[3] = {e.x, e.y, e.z};
  return insphere(pa, pb, pc, pd, pe);
}

void check_quality_options(const QualityOptions& options) {
  // TetGen's refinement is only known to end for looser bounds (1.1/20 ran without end on a small sphere).
  if (!(options.max_radius_edge >= 1.2) || !(options.min_dihedral <= 18.0) || options.min_dihedral < 0)
    throw std::invalid_argument("volume mesh: max radius-edge ratio must be >= 1.2 and min dihedral angle in [0, 18] "
                                "degrees, got " + std::to_string(options.max_radius_edge) + " and " +
                                std::to_string(options.min_dihedral));
}

void put_tets(ByteWriter& w, const Tets& t) {
  w.put(t.points);
  w.put(t.tets);
  w.put(t.region);
  w.put(t.faces);
  w.put(t.face_marker);
  w.put(t.neighbours);
}

bool get_tets(ByteReader& r, Tets& t) {
  return r.get(t.points) && r.get(t.tets) && r.get(t.region) && r.get(t.faces) && r.get(t.face_marker) && r.get(t.neighbours);
}

Tets constrained_quality(const std::vector<glm::dvec3>& points, const std::vector<std::array<uint32_t, 3>>& triangles,
                         const std::vector<int>& markers, const std::vector<Region>& regions,
                         const QualityOptions& options, const std::vector<glm::dvec3>& holes,
                         const std::vector<glm::dvec3>& interior) {
  check_quality_options(options);  // in this process, so that it stays a std::invalid_argument
  const std::string out = run_in_child("TetGen", [&] {
    ByteWriter w;
    put_tets(w, constrained_quality_in_this_process(points, triangles, markers, regions, options, holes, interior));
    return w.take();
  });
  Tets t;
  ByteReader r(out);
  if (!get_tets(r, t) || !r.done()) throw std::runtime_error("TetGen: truncated result from the child process");
  return t;
}

Tets constrained_quality_in_this_process(const std::vector<glm::dvec3>& points,
                                         const std::vector<std::array<uint32_t, 3>>& triangles,
                                         const std::vector<int>& markers, const std::vector<Region>& regions,
                                         const QualityOptions& options, const std::vector<glm::dvec3>& holes,
                                         const std::vector<glm::dvec3>& interior) {
  check_quality_options(options);
  // Only the triangles' vertices go to TetGen. The caller's list also holds points no triangle uses (particles left
  // out near junctions, merged duplicates), and TetGen drops an input point that coincides with another from its
  // output list, which would shift every later index.
  std::vector<uint8_t> referenced(points.size(), 0);
  for (const auto& tri : triangles)
    for (uint32_t v : tri) referenced[v] = 1;
  std::vector<uint32_t> compact(points.size(), UINT32_MAX), used;  // caller index <-> TetGen index
  for (uint32_t v = 0; v < points.size(); ++v)
    if (referenced[v]) {
      compact[v] = uint32_t(used.size());
      used.push_back(v);
    }
  // The interior points after the surface's: TetGen keeps the input points' order, so they cannot shift a surface
  // vertex (one it drops, outside every region, only shifts the points after it, all of them new to the caller).
  std::vector<glm::dvec3> input_points;
  input_points.reserve(used.size() + interior.size());
  for (uint32_t v : used) input_points.push_back(points[v]);
  input_points.insert(input_points.end(), interior.begin(), interior.end());
  tetgenio in;
  set_points(in, input_points);
  in.numberoffacets = int(triangles.size());
  in.facetlist = new tetgenio::facet[triangles.size()];
  in.facetmarkerlist = new int[triangles.size()];
  for (size_t i = 0; i < triangles.size(); ++i) {
    tetgenio::facet& f = in.facetlist[i];
    f.numberofpolygons = 1;
    f.polygonlist = new tetgenio::polygon[1];
    f.numberofholes = 0;
    f.holelist = nullptr;
    f.polygonlist[0].numberofvertices = 3;
    f.polygonlist[0].vertexlist = new int[3];
    for (int a = 0; a < 3; ++a) f.polygonlist[0].vertexlist[a] = int(compact[triangles[i][size_t(a)]]);
    in.facetmarkerlist[i] = markers.empty() ? 0 : markers[i];
  }
  in.numberofregions = int(regions.size());
  in.regionlist = new REAL[regions.size() * 5];
  for (size_t r = 0; r < regions.size(); ++r) {
    in.regionlist[5 * r + 0] = regions[r].seed.x;
    in.regionlist[5 * r + 1] = regions[r].seed.y;
    in.regionlist[5 * r + 2] = regions[r].seed.z;
    in.regionlist[5 * r + 3] = regions[r].attribute;
    in.regionlist[5 * r + 4] = -1;
  }
  in.numberofholes = int(holes.size());
  in.holelist = new REAL[holes.size() * 3];
  for (size_t h = 0; h < holes.size(); ++h)
    for (int a = 0; a < 3; ++a) in.holelist[3 * h + size_t(a)] = holes[h][a];
  std::ostringstream sw;
  sw << "pq" << options.max_radius_edge;
  if (options.dihedral_in_tetgen) sw << "/" << options.min_dihedral;
  sw << "AQz";
  if (options.max_volume > 0) sw << "a" << options.max_volume;
  if (options.keep_surface) sw << "Y";
  tetgenio tetgen_out;
  run(sw.str(), in, tetgen_out);
  Tets t = read_output(tetgen_out);
  // TetGen keeps the input points first, in order, unless it jettisons some: points left outside every region,
  // which happens when a material's boundary is not closed and its region leaks into the outside. The caller's
  // triangles and fixed vertices would then index the wrong points.
  size_t kept = 0;
  while (kept < used.size() && kept < t.points.size() && t.points[kept] == input_points[kept]) ++kept;
  if (kept < used.size())
    throw std::runtime_error("TetGen dropped surface vertices (" + std::to_string(used.size()) + " given, the first " +
                             std::to_string(kept) + " kept in place): a material's boundary is not closed, so its "
                             "region leaked outside");
  // Back to the caller's numbering: all of its points first (those no triangle uses are in no tet), then the new ones.
  auto caller_index = [&](uint32_t j) {
    return j < used.size() ? used[j] : uint32_t(points.size() + (j - used.size()));
  };
  for (auto& tet : t.tets)
    for (auto& v : tet) v = caller_index(v);
  for (auto& f : t.faces)
    for (auto& v : f) v = caller_index(v);
  std::vector<glm::dvec3> all = points;
  all.insert(all.end(), t.points.begin() + std::ptrdiff_t(used.size()), t.points.end());
  t.points = std::move(all);
  return t;
}

}  // namespace cpmesh::mesh
