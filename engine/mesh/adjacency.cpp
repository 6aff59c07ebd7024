#include "mesh/adjacency.h"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mesh/face_key.h"

namespace cpmesh::mesh {

namespace {

constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};  // face opposite corner c

}  // namespace

Adjacency build_adjacency(const Tets& T) {
  if (T.neighbours.size() == T.tets.size() * 4) {
    // TetGen's neighbours: for each pair, the corner of each tet that the other lacks names the shared face. Found
    // by vertices, so TetGen's slot order does not matter.
    Adjacency adj;
    adj.neighbour.assign(T.tets.size() * 4, Adjacency::kHull);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, T.tets.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t t = r.begin(); t < r.end(); ++t)
        for (int s = 0; s < 4; ++s) {
          const int32_t n = T.neighbours[t * 4 + size_t(s)];
          if (n < 0) continue;
          const auto &a = T.tets[t], &b = T.tets[size_t(n)];
          auto lacking = [](const std::array<uint32_t, 4>& x, const std::array<uint32_t, 4>& y) {
            for (int c = 0; c < 4; ++c)
              if (std::find(y.begin(), y.end(), x[size_t(c)]) == y.end()) return c;
            return -1;
          };
          const int ca = lacking(a, b), cb = lacking(b, a);
          if (ca >= 0 && cb >= 0) adj.neighbour[t * 4 + size_t(ca)] = uint32_t(size_t(n) * 4 + size_t(cb));
        }
    });
    return adj;
  }
  std::vector<std::pair<FaceKey, uint32_t>> faces;  // (face, tet * 4 + corner)
  faces.reserve(T.tets.size() * 4);
  for (size_t t = 0; t < T.tets.size(); ++t)
    for (int c = 0; c < 4; ++c)
      faces.push_back({FaceKey({T.tets[t][size_t(kFace[c][0])], T.tets[t][size_t(kFace[c][1])], T.tets[t][size_t(kFace[c][2])]}),
                       uint32_t(t * 4 + size_t(c))});
  std::sort(faces.begin(), faces.end());
  Adjacency adj;
  adj.neighbour.assign(T.tets.size() * 4, Adjacency::kHull);
  for (size_t i = 0; i + 1 < faces.size(); ++i)
    if (faces[i].first == faces[i + 1].first) {
      adj.neighbour[faces[i].second] = faces[i + 1].second;
      adj.neighbour[faces[i + 1].second] = faces[i].second;
    }
  return adj;
}

}  // namespace cpmesh::mesh
