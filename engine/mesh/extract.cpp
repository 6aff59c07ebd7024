#include "mesh/extract.h"

#include <algorithm>

#include <tbb/parallel_for.h>

namespace cpmesh::mesh {

namespace {

constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};  // face opposite corner c

uint64_t face_key(uint32_t a, uint32_t b, uint32_t c) {
  uint32_t v[3] = {a, b, c};
  std::sort(v, v + 3);
  return (uint64_t(v[0]) << 42) | (uint64_t(v[1]) << 21) | uint64_t(v[2]);
}

}  // namespace

glm::dvec3 circumcentre(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d, bool& ok) {
  const glm::dvec3 u = b - a, v = c - a, w = d - a;
  const double det = glm::dot(u, glm::cross(v, w));
  const double scale = glm::length(u) * glm::length(v) * glm::length(w);
  ok = std::fabs(det) > 1e-9 * scale;
  if (!ok) return (a + b + c + d) / 4.0;
  return a + (glm::dot(u, u) * glm::cross(v, w) + glm::dot(v, v) * glm::cross(w, u) + glm::dot(w, w) * glm::cross(u, v)) / (2 * det);
}

std::vector<uint16_t> label_tets(const fields::IndicatorFields& F, const Tets& T) {
  std::vector<uint16_t> m(T.tets.size());
  const glm::dvec3 hi = glm::dvec3(F.grid.dims - 1);
  tbb::parallel_for(size_t(0), T.tets.size(), [&](size_t t) {
    const auto& v = T.tets[t];
    bool ok;
    const glm::dvec3 c = circumcentre(T.points[v[0]], T.points[v[1]], T.points[v[2]], T.points[v[3]], ok);
    m[t] = uint16_t(F.material_at(glm::clamp(c / F.grid.spacing, glm::dvec3(0.0), hi)));
  });
  return m;
}

InterfaceMesh extract_interfaces(const fields::IndicatorFields& F, const Tets& T, const std::vector<uint16_t>& material,
                                 const std::vector<uint8_t>& vertex_kind) {
  if (T.points.size() >= (size_t(1) << 21)) throw std::runtime_error("interface extraction: at most 2M vertices");
  InterfaceMesh out;
  out.vertices = T.points;
  out.vertex_kind = vertex_kind;
  // Faces sorted by key: a face shared by two tets appears twice in a row.
  std::vector<std::pair<uint64_t, uint32_t>> faces;  // (key, tet * 4 + corner)
  faces.reserve(T.tets.size() * 4);
  for (size_t t = 0; t < T.tets.size(); ++t)
    for (int c = 0; c < 4; ++c) {
      const auto& v = T.tets[t];
      faces.push_back({face_key(v[size_t(kFace[c][0])], v[size_t(kFace[c][1])], v[size_t(kFace[c][2])]), uint32_t(t * 4 + size_t(c))});
    }
  std::sort(faces.begin(), faces.end());
  // The face of tet t opposite corner c, oriented with its normal pointing out of t.
  auto outward = [&](uint32_t tc) {
    const auto& v = T.tets[tc / 4];
    const int c = int(tc % 4);
    std::array<uint32_t, 3> f = {v[size_t(kFace[c][0])], v[size_t(kFace[c][1])], v[size_t(kFace[c][2])]};
    const glm::dvec3 n = glm::cross(T.points[f[1]] - T.points[f[0]], T.points[f[2]] - T.points[f[0]]);
    if (glm::dot(n, T.points[v[size_t(c)]] - T.points[f[0]]) > 0) std::swap(f[1], f[2]);
    return f;
  };
  const double step = 0.5 * F.grid.min_spacing();
  for (size_t i = 0; i < faces.size();) {
    const bool shared = i + 1 < faces.size() && faces[i + 1].first == faces[i].first;
    const uint32_t a = faces[i].second;
    const uint16_t ma = material[a / 4];
    uint16_t mb;
    if (shared) {
      mb = material[faces[i + 1].second / 4];
    } else {
      // A hull face: the material just outside it.
      const auto f = outward(a);
      const glm::dvec3 c = (T.points[f[0]] + T.points[f[1]] + T.points[f[2]]) / 3.0;
      const glm::dvec3 n = glm::normalize(glm::cross(T.points[f[1]] - T.points[f[0]], T.points[f[2]] - T.points[f[0]]));
      mb = uint16_t(F.material_at((c + step * n) / F.grid.spacing));
    }
    if (ma != mb) {
      // Emit from the side of the smaller material index, so the normal points into the larger one.
      uint32_t from = a;
      if (ma > mb && shared) from = faces[i + 1].second;
      auto f = outward(from);
      if (ma > mb && !shared) std::swap(f[1], f[2]);  // only tet a exists: flip to point into the larger (a's) side
      out.triangles.push_back(f);
      out.pair.push_back({std::min(ma, mb), std::max(ma, mb)});
    }
    i += shared ? 2 : 1;
  }
  return out;
}

}  // namespace cpmesh::mesh
