#include "mesh/small_labels.h"

#include <algorithm>
#include <map>
#include <stdexcept>

namespace cpmesh::mesh {

LabelCensus label_census(const io::LabelVolume& volume) {
  LabelCensus count(65536, 0);
  for (uint16_t l : volume.labels) ++count[l];
  return count;
}

std::vector<DroppedLabel> small_labels(const io::LabelVolume& v, const LabelCensus& count, int64_t min_voxels) {
  if (count.size() != 65536) throw std::invalid_argument("small_labels: a census has 65536 entries");
  std::vector<uint8_t> small(65536, 0);
  for (size_t l = 1; l < count.size(); ++l) small[l] = count[l] > 0 && count[l] < min_voxels;
  std::vector<DroppedLabel> out;
  if (min_voxels <= 1) return out;
  // Face neighbours of every small label's voxels, counted per neighbouring label.
  std::map<uint16_t, std::map<uint16_t, int64_t>> touches;
  for (int64_t k = 0; k < v.dims[2]; ++k)
    for (int64_t j = 0; j < v.dims[1]; ++j)
      for (int64_t i = 0; i < v.dims[0]; ++i) {
        const uint16_t l = v.labels[v.index(i, j, k)];
        if (!small[l]) continue;
        auto& t = touches[l];
        const int64_t n[6][3] = {{i - 1, j, k}, {i + 1, j, k}, {i, j - 1, k}, {i, j + 1, k}, {i, j, k - 1}, {i, j, k + 1}};
        for (const auto& q : n) {
          const bool outside = q[0] < 0 || q[1] < 0 || q[2] < 0 || q[0] >= v.dims[0] || q[1] >= v.dims[1] || q[2] >= v.dims[2];
          const uint16_t o = outside ? 0 : v.labels[v.index(q[0], q[1], q[2])];
          if (o != l) ++t[o];
        }
      }
  for (const auto& [label, t] : touches) {
    // The kept label touched most (ties: the lower label); a small one only where no kept label touches it.
    auto better = [&](const std::pair<const uint16_t, int64_t>& a, const std::pair<const uint16_t, int64_t>& b) {
      if (small[a.first] != small[b.first]) return small[b.first] > small[a.first];
      return a.second != b.second ? a.second > b.second : a.first < b.first;
    };
    uint16_t into = 0;
    if (!t.empty()) into = std::min_element(t.begin(), t.end(), better)->first;
    out.push_back({label, count[label], into});
  }
  // A small label that joined another small one follows that one to where it goes (chains end: each step goes to a
  // label with more touches or a kept one, and a label never joins itself).
  for (auto& d : out)
    for (int step = 0; step < 64 && small[d.merged_into]; ++step) {
      const auto next = std::find_if(out.begin(), out.end(), [&](const DroppedLabel& e) { return e.label == d.merged_into; });
      if (next == out.end() || next->merged_into == d.label) break;
      d.merged_into = next->merged_into;
    }
  return out;
}

io::LabelVolume merge_labels(const io::LabelVolume& volume, const std::vector<DroppedLabel>& dropped) {
  io::LabelVolume out = volume;
  std::vector<uint16_t> map(65536);
  for (size_t l = 0; l < map.size(); ++l) map[l] = uint16_t(l);
  for (const auto& d : dropped) map[d.label] = d.merged_into;
  for (auto& l : out.labels) l = map[l];
  return out;
}

LabelCensus merge_labels(LabelCensus census, const std::vector<DroppedLabel>& dropped) {
  for (const auto& d : dropped) {
    census[d.merged_into] += census[d.label];
    census[d.label] = 0;
  }
  return census;
}

}  // namespace cpmesh::mesh
