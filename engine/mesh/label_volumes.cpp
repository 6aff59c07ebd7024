#include "mesh/label_volumes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <span>

#include "fields/closest_point_embedding.h"
#include "mesh/quality.h"
#include "mesh/smooth.h"

namespace cpmesh::mesh {

namespace {

uint64_t edge_hash(uint32_t a, uint32_t b) {  // splitmix64 of the sorted pair
  uint64_t x = (uint64_t(std::min(a, b)) << 32 | std::max(a, b)) + 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// Per vertex that may move: its unit normal, pointing from its interface's pair[0] into pair[1], that pair, and how
// far it may go (a quarter of its shortest edge: where a thin part pinches, its tiny triangles would turn over or
// into slivers); vertices of junctions, of two interfaces or with no normal get pair {-1, -1}.
struct Movable {
  std::vector<glm::dvec3> normal;
  std::vector<std::array<int, 2>> pair;
  std::vector<double> reach;
};

Movable movable_vertices(const InterfaceMesh& mesh, const std::vector<uint8_t>& kind) {
  const size_t n = mesh.vertices.size();
  Movable out{std::vector<glm::dvec3>(n, glm::dvec3(0.0)), std::vector<std::array<int, 2>>(n, {-2, -2}),
              std::vector<double>(n, std::numeric_limits<double>::infinity())};
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const glm::dvec3 area = triangle_normal(mesh.vertices, tri);
    const std::array<int, 2> pr = {int(mesh.pair[t][0]), int(mesh.pair[t][1])};
    for (int c = 0; c < 3; ++c) {
      const uint32_t v = tri[size_t(c)];
      const double shortest = std::min(glm::length(mesh.vertices[tri[size_t((c + 1) % 3)]] - mesh.vertices[v]),
                                       glm::length(mesh.vertices[tri[size_t((c + 2) % 3)]] - mesh.vertices[v]));
      out.reach[v] = std::min(out.reach[v], 0.25 * shortest);
      out.normal[v] += area;
      if (out.pair[v][0] == -2) out.pair[v] = pr;
      else if (out.pair[v] != pr) out.pair[v] = {-1, -1};
    }
  }
  for (size_t v = 0; v < n; ++v) {
    const double len = glm::length(out.normal[v]);
    if (kind[v] != uint8_t(fields::FeatureKind::interface) || out.pair[v][0] < 0 || !(len > 0)) {
      out.pair[v] = {-1, -1};
      continue;
    }
    out.normal[v] /= len;
  }
  return out;
}

// The largest relative volume error over the measured materials, and where.
std::pair<double, int> worst_error(const std::vector<double>& volume, const std::vector<double>& target,
                                   const std::vector<uint8_t>& measured) {
  std::pair<double, int> worst{0.0, -1};
  for (size_t m = 0; m < volume.size(); ++m) {
    if (!measured[m]) continue;
    const double e = std::fabs(volume[m] - target[m]) / target[m];
    if (worst.second < 0 || e > worst.first) worst = {e, int(m)};
  }
  return worst;
}

}  // namespace

std::vector<double> enclosed_volumes(const InterfaceMesh& mesh, size_t materials) {
  std::vector<double> volume(materials, 0.0);
  if (mesh.vertices.empty()) return volume;
  // About the vertices' mean, so the sums do not cancel far from the origin.
  glm::dvec3 centre(0.0);
  for (const auto& p : mesh.vertices) centre += p;
  centre /= double(mesh.vertices.size());
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const double six = glm::dot(mesh.vertices[tri[0]] - centre,
                                glm::cross(mesh.vertices[tri[1]] - centre, mesh.vertices[tri[2]] - centre));
    volume[mesh.pair[t][0]] += six / 6;  // (the normal points out of pair[0])
    volume[mesh.pair[t][1]] -= six / 6;
  }
  return volume;
}

std::vector<uint8_t> closed_materials(const InterfaceMesh& mesh, size_t materials) {
  std::vector<uint64_t> parity(materials, 0);
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const uint64_t h = edge_hash(tri[0], tri[1]) ^ edge_hash(tri[1], tri[2]) ^ edge_hash(tri[2], tri[0]);
    parity[mesh.pair[t][0]] ^= h;
    parity[mesh.pair[t][1]] ^= h;
  }
  std::vector<uint8_t> closed(materials);
  for (size_t m = 0; m < materials; ++m) closed[m] = parity[m] == 0;
  return closed;
}

namespace {

// Whether vertex v may go to p: every tet around it keeps its orientation, and keeps its smallest dihedral angle at
// the bound if it had it, or at its own if it had less.
bool tets_allow(const std::vector<glm::dvec3>& points, const std::vector<std::array<uint32_t, 4>>& tets,
                std::span<const uint32_t> around, uint32_t v, const glm::dvec3& p, double bound_rad) {
  for (uint32_t t : around) {
    const auto& tet = tets[t];
    std::array<glm::dvec3, 4> q;
    for (size_t c = 0; c < 4; ++c) q[c] = tet[c] == v ? p : points[tet[c]];
    if (!(signed_volume6(q[0], q[1], q[2], q[3]) * signed_volume6(points, tet) > 0)) return false;
    const double was = min_dihedral(points, tet), now = min_dihedral(q[0], q[1], q[2], q[3]);
    if (now < std::min(was, bound_rad)) return false;
  }
  return true;
}

std::vector<double> interface_areas(const InterfaceMesh& mesh, size_t materials) {
  std::vector<double> area(materials, 0.0);
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const double a = 0.5 * glm::length(triangle_normal(mesh.vertices, mesh.triangles[t]));
    area[mesh.pair[t][0]] += a;
    area[mesh.pair[t][1]] += a;
  }
  return area;
}

// Every movable vertex to `start` plus the difference of its sides' growth along its normal (within its reach),
// where the volume mesh's tets allow it. Returns the moves refused.
size_t move_vertices(const std::vector<double>& grow, const Movable& movable, const std::vector<glm::dvec3>& start,
                     InterfaceMesh& mesh, const TetsAround& volume_mesh) {
  const double bound = volume_mesh.min_dihedral_deg * std::numbers::pi / 180;
  size_t refused = 0;
  for (size_t v = 0; v < start.size(); ++v) {
    const auto [a, b] = movable.pair[v];
    if (a < 0) continue;
    const double along = std::clamp(grow[size_t(a)] - grow[size_t(b)], -movable.reach[v], movable.reach[v]);
    const glm::dvec3 p = start[v] + along * movable.normal[v];
    if (p == mesh.vertices[v]) continue;
    if (volume_mesh.points) {
      auto& points = *volume_mesh.points;
      if (!tets_allow(points, *volume_mesh.tets, (*volume_mesh.around)[uint32_t(v)], uint32_t(v), p, bound)) {
        ++refused;
        continue;
      }
      points[v] = p;
    }
    mesh.vertices[v] = p;
  }
  return refused;
}

}  // namespace

LabelVolumeReport match_label_volumes(InterfaceMesh& mesh, const std::vector<uint8_t>& kind,
                                      const std::vector<double>& target, const std::vector<uint8_t>& measured_in,
                                      double voxel_size, const LabelVolumeOptions& options, const TetsAround& volume_mesh) {
  LabelVolumeReport report;
  const size_t materials = target.size();
  std::vector<uint8_t> measured = measured_in;
  const std::vector<uint8_t> closed = closed_materials(mesh, materials);
  std::vector<double> volume = enclosed_volumes(mesh, materials);
  for (size_t m = 0; m < materials; ++m) measured[m] = measured[m] && closed[m] && target[m] > 0 && volume[m] > 0;
  std::tie(report.worst_before, report.worst_material) = worst_error(volume, target, measured);
  report.worst_after = report.worst_before;
  if (options.tolerance <= 0 || options.rounds <= 0) return report;

  std::vector<uint8_t> moving(materials, 0);
  for (size_t m = 0; m < materials; ++m)
    if (measured[m] && std::fabs(volume[m] - target[m]) > options.tolerance * target[m]) moving[m] = 1, ++report.labels_moved;
  if (report.labels_moved == 0) return report;
  const std::vector<double> area = interface_areas(mesh, materials);  // a label's growth in volume per unit distance
  const Movable movable = movable_vertices(mesh, kind);
  const std::vector<glm::dvec3> start = mesh.vertices;
  const double limit = options.max_move * voxel_size;
  std::vector<double> grow(materials, 0.0);  // outward distance per material
  for (int round = 0; round < options.rounds; ++round) {
    for (size_t m = 0; m < materials; ++m)
      if (moving[m] && area[m] > 0) grow[m] = std::clamp(grow[m] + (target[m] - volume[m]) / area[m], -limit, limit);
    report.moves_refused += move_vertices(grow, movable, start, mesh, volume_mesh);
    volume = enclosed_volumes(mesh, materials);
  }
  report.moves_undone = undo_crossings(start, mesh.triangles, mesh.vertices);
  if (report.moves_undone > 0) {
    volume = enclosed_volumes(mesh, materials);
    if (volume_mesh.points) std::copy(mesh.vertices.begin(), mesh.vertices.end(), volume_mesh.points->begin());
  }
  std::tie(report.worst_after, report.worst_material) = worst_error(volume, target, measured);
  return report;
}

}  // namespace cpmesh::mesh
