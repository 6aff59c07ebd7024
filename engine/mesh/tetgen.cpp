#include "mesh/tetgen.h"

#include <cstdio>
#include <cstring>
#include <sstream>
#include <stdexcept>

#include <tetgen.h>

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
  for (int i = 0; i < out.numberoftrifaces; ++i) {
    t.faces.push_back({uint32_t(out.trifacelist[3 * i]), uint32_t(out.trifacelist[3 * i + 1]),
                       uint32_t(out.trifacelist[3 * i + 2])});
    t.face_marker.push_back(out.trifacemarkerlist ? out.trifacemarkerlist[i] : 0);
  }
  return t;
}

void run(const std::string& switches, tetgenio& in, tetgenio& out) {
  std::vector<char> sw(switches.begin(), switches.end());
  sw.push_back('\0');
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
  tetgenio in, out;
  set_points(in, points);
  run("Qz", in, out);
  Tets t = read_output(out);
  t.points = points;  // no Steiner points: keep the exact input
  return t;
}

Tets constrained_quality(const std::vector<glm::dvec3>& points, const std::vector<std::array<uint32_t, 3>>& triangles,
                         const std::vector<int>& markers, const std::vector<Region>& regions,
                         const QualityOptions& options) {
  // TetGen's refinement is only known to end for looser bounds (1.1/20 ran without end on a small sphere).
  if (!(options.max_radius_edge >= 1.2) || !(options.min_dihedral <= 18.0) || options.min_dihedral < 0)
    throw std::invalid_argument("volume mesh: max radius-edge ratio must be >= 1.2 and min dihedral angle in [0, 18] "
                                "degrees, got " + std::to_string(options.max_radius_edge) + " and " +
                                std::to_string(options.min_dihedral));
  tetgenio in, out;
  set_points(in, points);
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
    for (int a = 0; a < 3; ++a) f.polygonlist[0].vertexlist[a] = int(triangles[i][size_t(a)]);
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
  std::ostringstream sw;
  sw << "pq" << options.max_radius_edge << "/" << options.min_dihedral << "AQz";
  if (options.max_volume > 0) sw << "a" << options.max_volume;
  if (options.keep_surface) sw << "Y";
  run(sw.str(), in, out);
  return read_output(out);
}

}  // namespace cpmesh::mesh
