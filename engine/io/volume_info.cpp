#include "io/volume_info.h"

#include <algorithm>
#include <cstdio>
#include <set>
#include <sstream>

#include "io/header_text.h"

namespace cpmesh::io {

VolumeInfo summarize(const LabelVolume& v) {
  VolumeInfo info;
  info.geometry = v;
  info.format = v.format;
  info.source = v.source;
  info.type = scalar_name(v.file_type);
  // Dense per-label tables: labels are uint16, so 65536 entries cost less than hashing every voxel.
  std::vector<int64_t> count(65536, 0);
  std::vector<std::array<int64_t, 6>> box(65536, {INT64_MAX, INT64_MAX, INT64_MAX, -1, -1, -1});
  std::set<std::pair<uint16_t, uint16_t>> pairs;
  std::pair<uint16_t, uint16_t> last{0, 0};
  auto touch = [&](uint16_t a, uint16_t b) {
    const std::pair<uint16_t, uint16_t> p{std::min(a, b), std::max(a, b)};
    if (p != last) pairs.insert(p), last = p;
  };
  const auto& d = v.dims;
  for (int64_t k = 0; k < d[2]; ++k)
    for (int64_t j = 0; j < d[1]; ++j)
      for (int64_t i = 0; i < d[0]; ++i) {
        const size_t at = v.index(i, j, k);
        const uint16_t l = v.labels[at];
        ++count[l];
        auto& b = box[l];
        b = {std::min(b[0], i), std::min(b[1], j), std::min(b[2], k), std::max(b[3], i), std::max(b[4], j),
             std::max(b[5], k)};
        if (i + 1 < d[0] && v.labels[at + 1] != l) touch(l, v.labels[at + 1]);
        if (j + 1 < d[1] && v.labels[at + size_t(d[0])] != l) touch(l, v.labels[at + size_t(d[0])]);
        if (k + 1 < d[2] && v.labels[at + size_t(d[0] * d[1])] != l) touch(l, v.labels[at + size_t(d[0] * d[1])]);
      }
  for (size_t l = 0; l < count.size(); ++l) {
    if (!count[l]) continue;
    LabelInfo li;
    li.label = uint16_t(l);
    li.voxels = count[l];
    for (int a = 0; a < 3; ++a) {
      li.min_voxel[a] = box[l][a];
      li.max_voxel[a] = box[l][a + 3];
      li.min_physical[a] = v.origin[a] + (double(li.min_voxel[a]) - 0.5) * v.spacing[a];
      li.max_physical[a] = v.origin[a] + (double(li.max_voxel[a]) + 0.5) * v.spacing[a];
    }
    for (const auto& [a, b] : pairs) {
      if (a == l) li.neighbours.push_back(b);
      if (b == l) li.neighbours.push_back(a);
    }
    std::sort(li.neighbours.begin(), li.neighbours.end());
    info.labels.push_back(li);
  }
  return info;
}

std::string format_volume_info(const VolumeInfo& info, int64_t few_voxels) {
  std::ostringstream out;
  const auto& g = info.geometry;
  auto triple = [](const auto& a) { return format_double(double(a[0])) + " x " + format_double(double(a[1])) + " x " +
                                           format_double(double(a[2])); };
  out << info.source << " (" << info.format << ", " << info.type << ")\n"
      << "  dims     " << triple(g.dims) << " = " << g.voxel_count() << " voxels\n"
      << "  spacing  " << format_vector(g.spacing[0], g.spacing[1], g.spacing[2]) << "\n"
      << "  origin   " << format_vector(g.origin[0], g.origin[1], g.origin[2]) << "  (centre of voxel 0,0,0)\n"
      << "  labels   " << info.labels.size() << "\n";
  char line[512];
  std::snprintf(line, sizeof line, "  %6s %12s %9s  %-26s %-44s %s\n", "label", "voxels", "share", "voxel box (min..max)",
                "physical box", "neighbours (6-connected)");
  out << line;
  std::vector<std::string> warnings;
  for (const auto& l : info.labels) {
    std::string nb;
    for (uint16_t n : l.neighbours) {
      if (!nb.empty()) nb += ' ';
      nb += std::to_string(n);
    }
    char vbox[160];
    std::snprintf(vbox, sizeof vbox, "(%lld,%lld,%lld)..(%lld,%lld,%lld)", (long long)l.min_voxel[0],
                  (long long)l.min_voxel[1], (long long)l.min_voxel[2], (long long)l.max_voxel[0],
                  (long long)l.max_voxel[1], (long long)l.max_voxel[2]);
    char pbox[128];
    std::snprintf(pbox, sizeof pbox, "(%.4g,%.4g,%.4g)..(%.4g,%.4g,%.4g)", l.min_physical[0], l.min_physical[1],
                  l.min_physical[2], l.max_physical[0], l.max_physical[1], l.max_physical[2]);
    std::snprintf(line, sizeof line, "  %6u %12lld %8.3f%%  %-26s %-44s %s\n", unsigned(l.label), (long long)l.voxels,
                  100.0 * double(l.voxels) / double(g.voxel_count()), vbox, pbox, nb.empty() ? "-" : nb.c_str());
    out << line;
    if (l.voxels < few_voxels)
      warnings.push_back("warning: label " + std::to_string(l.label) + " has only " + std::to_string(l.voxels) +
                         " voxels (fewer than " + std::to_string(few_voxels) + "): likely noise; too small to mesh well");
  }
  for (const auto& w : warnings) out << w << '\n';
  return out.str();
}

}  // namespace cpmesh::io
