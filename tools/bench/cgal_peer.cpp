// Peer for the pipeline benchmark (issue 9): CGAL Mesh_3 on a labeled image (Labeled_mesh_domain_3), the tool many
// users mesh segmentations with today. Built only when CGAL is installed (libcgal-dev; tools/install-deps.sh does not
// install it). Reads the same volumes as cpmesh-bench-pipeline (shape:size or a file, through cpmesh's readers),
// meshes with facet size and cell size in voxels, and prints one JSON line: time, surface triangles (facets of the
// complex), radius ratio mean/min, min dihedral of the cells, vertex count, and on the wedge ball the junction error
// (bench_util.h junction_error, the same measure as cpmesh's row). With --write DIR it also writes DIR/interfaces.vtp
// and DIR/volume.vtu in cpmesh's layout and world coordinates, for cpmesh-check to read CGAL's mesh as it reads
// cpmesh's (docs/corpus.md). CGAL's labeled-image domain has no features, so each vertex's "feature" there is
// derived from the materials of its facets (two: interface, three: triple curve, more: quadruple point): the
// checker's manifold, boundary, closure, crossing, conformity, label and quality checks then read as they do for
// cpmesh, and its wrong-face check holds by construction.
//   cpmesh-peer-cgal VOLUME [--facet-size 1.5] [--facet-distance 0.5] [--cell-size 3] [--write DIR]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <set>
#include <string>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Image_3.h>
#include <CGAL/ImageIO.h>
#include <CGAL/Labeled_mesh_domain_3.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/make_mesh_3.h>

#include "bench_util.h"
#include "io/mesh_writers.h"
#include "mesh/quality.h"

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Domain = CGAL::Labeled_mesh_domain_3<K>;
using Tr = CGAL::Mesh_triangulation_3<Domain, CGAL::Default, CGAL::Sequential_tag>::type;
using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr>;
using Criteria = CGAL::Mesh_criteria_3<Tr>;

// CGAL's complex as cpmesh writes its own (io/mesh_writers.h), in the volume's world coordinates: the facets of the
// complex with their two subdomains (0 outside), the cells with theirs.
static void write_for_checker(const C3t3& c3t3, const cpmesh::io::LabelVolume& vol, const std::string& dir) {
  std::map<Tr::Vertex_handle, uint32_t> index;
  std::vector<std::array<double, 3>> points;
  auto id = [&](Tr::Vertex_handle v) {
    const auto [it, added] = index.emplace(v, uint32_t(points.size()));
    if (added) {
      const auto& q = v->point();
      points.push_back({CGAL::to_double(q.x()) + vol.origin[0], CGAL::to_double(q.y()) + vol.origin[1],
                        CGAL::to_double(q.z()) + vol.origin[2]});
    }
    return it->second;
  };
  cpmesh::io::TetMesh tets;
  for (auto f = c3t3.facets_in_complex_begin(); f != c3t3.facets_in_complex_end(); ++f) {
    std::array<uint32_t, 3> tri{};
    for (int k = 0, n = 0; k < 4; ++k)
      if (k != f->second) tri[size_t(n++)] = id(f->first->vertex(k));
    const auto mirror = c3t3.triangulation().mirror_facet(*f);
    tets.triangles.push_back(tri);
    tets.triangle_pair.push_back({uint16_t(c3t3.subdomain_index(f->first)), uint16_t(c3t3.subdomain_index(mirror.first))});
  }
  for (auto c = c3t3.cells_in_complex_begin(); c != c3t3.cells_in_complex_end(); ++c) {
    tets.tets.push_back({id(c->vertex(0)), id(c->vertex(1)), id(c->vertex(2)), id(c->vertex(3))});
    tets.tet_material.push_back(uint16_t(c3t3.subdomain_index(c)));
  }
  tets.vertices = points;
  std::vector<std::set<uint16_t>> around(points.size());
  for (size_t t = 0; t < tets.triangles.size(); ++t)
    for (uint32_t v : tets.triangles[t]) around[v].insert(tets.triangle_pair[t].begin(), tets.triangle_pair[t].end());
  cpmesh::io::TriangleMesh surface{points, tets.triangles, tets.triangle_pair, {}, {}};
  using cpmesh::io::VertexFeature;
  for (const auto& m : around)
    surface.vertex_feature.push_back(uint8_t(m.size() <= 2   ? VertexFeature::interface
                                             : m.size() == 3 ? VertexFeature::triple_curve
                                                             : VertexFeature::quadruple_point));
  std::filesystem::create_directories(dir);
  cpmesh::io::write_vtp(dir + "/interfaces.vtp", surface);
  cpmesh::io::write_vtu(dir + "/volume.vtu", tets);
}

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: cpmesh-peer-cgal VOLUME [--facet-size F] [--facet-distance D] [--cell-size C] [--write DIR]\n";
    return 2;
  }
  const std::string spec = argv[1];
  double facet_size = 1.5, facet_distance = 0.5, cell_size = 3.0;
  std::string write_dir;
  for (int a = 2; a + 1 < argc; a += 2) {
    const std::string k = argv[a];
    const double v = std::atof(argv[a + 1]);
    if (k == "--write") write_dir = argv[a + 1];
    else if (k == "--facet-size") facet_size = v;
    else if (k == "--facet-distance") facet_distance = v;
    else if (k == "--cell-size") cell_size = v;
    else {
      std::cerr << "cpmesh-peer-cgal: unknown option " << k << '\n';
      return 2;
    }
  }
  try {
    const auto loaded = cpmesh::bench::load_volume_spec(spec);
    const cpmesh::io::LabelVolume& vol = loaded.volume;
    const double voxel = std::min({vol.spacing[0], vol.spacing[1], vol.spacing[2]});
    _image* img = _createImage(size_t(vol.dims[0]), size_t(vol.dims[1]), size_t(vol.dims[2]), 1, vol.spacing[0],
                               vol.spacing[1], vol.spacing[2], 2, WK_FIXED, SGN_UNSIGNED);
    std::memcpy(img->data, vol.labels.data(), vol.labels.size() * sizeof(uint16_t));
    CGAL::Image_3 image(img);
    const auto t0 = std::chrono::steady_clock::now();
    Domain domain = Domain::create_labeled_image_mesh_domain(image);
    namespace p = CGAL::parameters;
    Criteria criteria(p::facet_angle = 30, p::facet_size = facet_size * voxel,
                      p::facet_distance = facet_distance * voxel, p::cell_radius_edge_ratio = 3,
                      p::cell_size = cell_size * voxel);
    C3t3 c3t3 = CGAL::make_mesh_3<C3t3>(domain, criteria);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    double rr_sum = 0, rr_min = 1;
    size_t facets = 0;
    // The surface as an indexed mesh with each facet's material pair, for the junction error.
    std::map<Tr::Vertex_handle, uint32_t> index;
    std::vector<std::array<double, 3>> vertices;
    std::vector<std::array<uint32_t, 3>> triangles;
    std::vector<std::array<uint16_t, 2>> pairs;
    for (auto f = c3t3.facets_in_complex_begin(); f != c3t3.facets_in_complex_end(); ++f) {
      const auto& cell = f->first;
      const int i = f->second;
      glm::dvec3 v[3];
      std::array<uint32_t, 3> tri{};
      for (int k = 0, n = 0; k < 4; ++k) {
        if (k == i) continue;
        const auto& q = cell->vertex(k)->point();
        v[n] = glm::dvec3(CGAL::to_double(q.x()), CGAL::to_double(q.y()), CGAL::to_double(q.z()));
        const auto [it, added] = index.emplace(cell->vertex(k), uint32_t(vertices.size()));
        if (added) vertices.push_back({v[n].x, v[n].y, v[n].z});
        tri[size_t(n++)] = it->second;
      }
      triangles.push_back(tri);
      const auto mirror = c3t3.triangulation().mirror_facet(*f);
      pairs.push_back({uint16_t(c3t3.subdomain_index(cell)), uint16_t(c3t3.subdomain_index(mirror.first))});
      const double rr = cpmesh::mesh::radius_ratio(v[0], v[1], v[2]);
      rr_sum += rr;
      rr_min = std::min(rr_min, rr);
      ++facets;
    }
    double dihedral_min = 180;
    size_t cells = 0;
    for (auto c = c3t3.cells_in_complex_begin(); c != c3t3.cells_in_complex_end(); ++c) {
      glm::dvec3 v[4];
      for (int k = 0; k < 4; ++k) {
        const auto& q = c->vertex(k)->point();
        v[k] = glm::dvec3(CGAL::to_double(q.x()), CGAL::to_double(q.y()), CGAL::to_double(q.z()));
      }
      for (double a : cpmesh::mesh::dihedral_angles(v[0], v[1], v[2], v[3])) dihedral_min = std::min(dihedral_min, a * 180 / M_PI);
      ++cells;
    }
    if (!write_dir.empty()) write_for_checker(c3t3, vol, write_dir);
    std::string junction;
    if (loaded.junctions)
      junction = ",\"junction_error\":" +
                 cpmesh::bench::junction_json(
                     cpmesh::mesh::junction_error(*loaded.junctions, vertices, triangles, pairs, voxel)).dump();
    std::printf("{\"benchmark\":\"pipeline_peer\",\"peer\":\"CGAL Mesh_3 %s\",\"volume\":\"%s\",\"facet_size_voxels\":%g,"
                "\"total_s\":%.4f,\"triangles\":%zu,\"tets\":%zu,\"vertices\":%zu,\"mean_radius_ratio\":%.4f,"
                "\"min_radius_ratio\":%.4f,\"min_dihedral_deg\":%.3f%s}\n",
                CGAL_VERSION_STR, spec.c_str(), facet_size, seconds, facets, cells,
                size_t(c3t3.triangulation().number_of_vertices()), facets ? rr_sum / double(facets) : 0.0, rr_min,
                dihedral_min, junction.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "cpmesh-peer-cgal: error: " << e.what() << '\n';
    return 1;
  }
}
