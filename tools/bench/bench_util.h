#pragma once
// Helpers shared by the benchmarks.
#include <sys/resource.h>

#include <algorithm>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/read_volume.h"
#include "io/synth_volumes.h"
#include "mesh/quality.h"

namespace cpmesh::bench {

// Peak resident set size of this process so far, MiB.
inline double peak_rss_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_maxrss) / 1024.0;
}

// A benchmark volume: "shape:size" (sphere, wedge-ball, slabs, shells; cpmesh-synth's volumes) or a volume file.
inline io::LabelVolume load_volume_spec(const std::string& spec) {
  const auto colon = spec.find(':');
  if (colon != std::string::npos && spec.find('.') == std::string::npos) {
    io::SynthOptions o;
    o.shape = io::parse_synth_shape(spec.substr(0, colon));
    o.size = std::stoi(spec.substr(colon + 1));
    auto v = io::make_synth_volume(o).volume;
    v.source = spec;
    return v;
  }
  return io::read_label_volume(spec);
}

// The analytic junctions of a synthetic volume spec (the wedge ball has some), or nothing for files.
inline std::optional<io::Junctions> synth_junctions(const std::string& spec) {
  const auto colon = spec.find(':');
  if (colon == std::string::npos || spec.find('.') != std::string::npos) return std::nullopt;
  io::SynthOptions o;
  o.shape = io::parse_synth_shape(spec.substr(0, colon));
  o.size = std::stoi(spec.substr(colon + 1));
  if (o.shape != io::SynthShape::wedge_ball) return std::nullopt;
  return io::make_synth_volume(o).junctions;
}

// Junction error of interface meshes (any mesher's): the mesh's triple-curve edges (mesh::triple_curve_edges), the
// distance of their midpoints to the analytic curves of the same three materials, in voxels; and the largest distance
// of any point of an edge (its ends and 7 points between them), where the ends' own errors (curve vertices,
// quadruple points) show.
struct JunctionError {
  size_t edges = 0;
  size_t spurious = 0;  // triple edges between three materials that have no curve in common
  double mean = 0, max = 0;
  double max_whole_edge = 0;
};
inline JunctionError junction_error(const io::Junctions& j, const std::vector<std::array<double, 3>>& vertices,
                                    const std::vector<std::array<uint32_t, 3>>& triangles,
                                    const std::vector<std::array<uint16_t, 2>>& pairs, double voxel) {
  JunctionError e;
  for (const auto& c : mesh::triple_curve_edges(triangles, pairs)) {
    const auto& a = vertices[c.a];
    const auto& b = vertices[c.b];
    const double d = io::distance_to_triple_curve(
        j, c.materials, {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])}) / voxel;
    if (!(d < 1e300)) {  // three materials with no analytic curve between them
      ++e.spurious;
      continue;
    }
    e.mean += d;
    e.max = std::max(e.max, d);
    for (int q = 0; q <= 8; ++q) {  // q = 4 is the midpoint
      const double t = q / 8.0;
      e.max_whole_edge = std::max(
          e.max_whole_edge,
          io::distance_to_triple_curve(j, c.materials,
                                       {a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])}) /
              voxel);
    }
    ++e.edges;
  }
  if (e.edges) e.mean /= double(e.edges);
  return e;
}

inline nlohmann::json junction_json(const JunctionError& e) {
  return {{"edges", e.edges}, {"spurious", e.spurious}, {"mean", e.mean}, {"max", e.max},
          {"max_whole_edge", e.max_whole_edge}};
}

}  // namespace cpmesh::bench
