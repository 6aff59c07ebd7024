#include "mesh/pipeline.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <numeric>

#include "fields/volume_grid.h"
#include "mesh/extract.h"

namespace cpmesh::mesh {

namespace {

// One tet per connected set of same-material Delaunay tets (through shared faces): the region seeds of the
// constrained mesh, so every component of every material gets its attribute.
std::vector<uint32_t> component_representatives(const Tets& T, const std::vector<uint16_t>& material) {
  std::vector<uint32_t> parent(T.tets.size());
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::vector<std::pair<uint64_t, uint32_t>> faces;
  faces.reserve(T.tets.size() * 4);
  for (size_t t = 0; t < T.tets.size(); ++t)
    for (int c = 0; c < 4; ++c) {
      uint32_t v[3], k = 0;
      for (int a = 0; a < 4; ++a)
        if (a != c) v[k++] = T.tets[t][size_t(a)];
      std::sort(v, v + 3);
      faces.push_back({(uint64_t(v[0]) << 42) | (uint64_t(v[1]) << 21) | v[2], uint32_t(t)});
    }
  std::sort(faces.begin(), faces.end());
  for (size_t i = 0; i + 1 < faces.size(); ++i)
    if (faces[i].first == faces[i + 1].first && material[faces[i].second] == material[faces[i + 1].second])
      parent[find(faces[i].second)] = find(faces[i + 1].second);
  std::vector<uint32_t> reps;
  for (uint32_t t = 0; t < T.tets.size(); ++t)
    if (find(t) == t) reps.push_back(t);
  return reps;
}

}  // namespace

MeshResult mesh_volume(gpu::Context& ctx, const io::LabelVolume& volume, const MeshOptions& options,
                       const StageCallback& on_stage) {
  using clock = std::chrono::steady_clock;
  MeshResult result;
  MeshReport& rep = result.report;
  auto t = clock::now();
  auto stage_done = [&](const std::string& name) {
    const auto now = clock::now();
    rep.seconds.emplace_back(name, std::chrono::duration<double>(now - t).count());
    t = now;
  };
  auto begin = [&](const std::string& name) {
    if (on_stage) on_stage(name);
  };

  begin("fields");
  const fields::Grid grid = fields::grid_of(volume);
  const auto F = fields::build_fields(grid, volume.labels.data(), options.fields);
  stage_done("fields");
  const auto& labels = F.fields.labels;

  begin("seeding");
  const auto seeds = particles::seed_population(F.embedding, options.population);
  stage_done("seeding");

  begin("advection");
  const auto relaxed = particles::relax(ctx, F.embedding, seeds, options.advection, options.population);
  stage_done("advection");
  const auto& P = relaxed.population;
  rep.particles = P.particles.size();
  rep.rounds = relaxed.rounds.size();
  rep.iterations = relaxed.iterations;
  rep.settled = relaxed.settled;
  rep.steady = relaxed.steady;

  begin("tetrahedralization");
  std::vector<glm::dvec3> points;
  std::vector<uint8_t> kind;
  for (size_t i = 0; i < P.particles.size(); ++i) {
    points.push_back(glm::dvec3(glm::vec3(P.particles[i])));
    kind.push_back(uint8_t(F.embedding.features[P.features[i]].kind));
  }
  const Tets T = delaunay(points);
  rep.delaunay_tets = T.tets.size();
  stage_done("tetrahedralization");

  begin("extraction");
  const auto material = label_tets(F.fields, T);
  const InterfaceMesh I = extract_interfaces(F.fields, T, material, kind);
  stage_done("extraction");

  begin("quality");
  std::vector<uint8_t> on_curve(kind.size());
  for (size_t v = 0; v < kind.size(); ++v) on_curve[v] = kind[v] != uint8_t(fields::FeatureKind::interface);
  rep.surface = triangle_stats(I.vertices, I.triangles);
  std::map<std::array<uint16_t, 2>, std::vector<std::array<uint32_t, 3>>> by_pair;
  for (size_t i = 0; i < I.triangles.size(); ++i) by_pair[I.pair[i]].push_back(I.triangles[i]);
  for (const auto& [pair, tris] : by_pair) {
    InterfaceReport ir;
    ir.labels = {labels[pair[0]], labels[pair[1]]};
    ir.quality = triangle_stats(I.vertices, tris);
    ir.check = check_surface(tris, on_curve);
    rep.interfaces_manifold += ir.check.manifold();
    rep.interfaces.push_back(ir);
  }
  for (size_t m = 0; m < labels.size(); ++m) {
    std::vector<std::array<uint32_t, 3>> boundary;
    for (size_t i = 0; i < I.triangles.size(); ++i)
      if (I.pair[i][0] == m || I.pair[i][1] == m) boundary.push_back(I.triangles[i]);
    MaterialReport mr;
    mr.label = labels[m];
    mr.boundary_triangles = boundary.size();
    mr.odd_edges = odd_edges(boundary);
    rep.materials_closed += mr.odd_edges == 0;
    rep.materials.push_back(mr);
  }
  stage_done("quality");

  // Outputs in physical units.
  for (const auto& p : I.vertices) {
    const glm::dvec3 q = grid.to_physical(p);
    result.surfaces.vertices.push_back({q.x, q.y, q.z});
  }
  result.surfaces.triangles = I.triangles;
  for (const auto& pr : I.pair) result.surfaces.triangle_pair.push_back({labels[pr[0]], labels[pr[1]]});
  result.surfaces.vertex_feature = kind;
  result.particles.vertices = result.surfaces.vertices;
  result.particles.vertex_feature = kind;
  std::vector<float> h;
  for (const auto& p : P.particles) h.push_back(p.w);
  result.particles.vertex_scalars = {{"sizing", h}};

  if (!options.only_surfaces) {
    begin("volume mesh");
    std::vector<Region> regions;
    for (uint32_t t : component_representatives(T, material)) {
      glm::dvec3 c(0.0);
      for (uint32_t v : T.tets[t]) c += T.points[v];
      regions.push_back({c / 4.0, int(material[t]) + 1});
    }
    std::vector<int> markers;
    for (const auto& pr : I.pair) markers.push_back(int(pr[0]) * 1000 + int(pr[1]) + 1);
    try {
      const Tets V = constrained_quality(I.vertices, I.triangles, markers, regions, options.volume);
      auto& out = result.volume;
      for (const auto& p : V.points) {
        const glm::dvec3 q = grid.to_physical(p);
        out.vertices.push_back({q.x, q.y, q.z});
      }
      const auto fallback = label_tets(F.fields, V);
      std::vector<std::vector<std::array<uint32_t, 4>>> per_material(labels.size());
      for (size_t i = 0; i < V.tets.size(); ++i) {
        const int region = V.region.empty() ? 0 : V.region[i];
        const uint16_t m = region >= 1 && size_t(region) <= labels.size() ? uint16_t(region - 1) : fallback[i];
        out.tets.push_back(V.tets[i]);
        out.tet_material.push_back(labels[m]);
        per_material[m].push_back(V.tets[i]);
      }
      out.triangles = I.triangles;  // -Y: the interface triangles are kept as they are, same vertex indices
      out.triangle_pair = result.surfaces.triangle_pair;
      rep.volume = tet_stats(V.points, V.tets);
      for (size_t m = 0; m < labels.size(); ++m) rep.materials[m].tets = tet_stats(V.points, per_material[m]);
    } catch (const std::exception& e) {
      rep.volume_error = e.what();
    }
    stage_done("volume mesh");
  }
  return result;
}

}  // namespace cpmesh::mesh
