#pragma once
// Helpers shared by the benchmarks.
#include <sys/resource.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
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

// A benchmark volume: "shape:size" (sphere, wedge-ball, slabs, shells, head; cpmesh-synth's volumes) or a volume
// file. The synthetic volume's options, or nothing for a file; a bad shape or size throws, naming the spec.
inline std::optional<io::SynthOptions> synth_spec(const std::string& spec) {
  const auto colon = spec.find(':');
  if (colon == std::string::npos || spec.find('.') != std::string::npos) return std::nullopt;
  io::SynthOptions o;
  o.shape = io::parse_synth_shape(spec.substr(0, colon));
  const std::string size = spec.substr(colon + 1);
  char* end = nullptr;
  const long n = std::strtol(size.c_str(), &end, 10);
  if (size.empty() || *end != '\0' || n < 8 || n > 4096)
    throw std::invalid_argument("volume '" + spec + "': field 'size': expected voxels per axis, 8 to 4096, got '" +
                                size + "'");
  o.size = n;
  return o;
}

// Checks a spec before any run starts: a synthetic volume's shape and size, or that the file exists.
inline void check_volume_spec(const std::string& spec) {
  if (!synth_spec(spec) && !std::filesystem::exists(spec))
    throw std::invalid_argument("volume '" + spec + "': no such file (or shape:size, e.g. wedge-ball:128)");
}

inline io::LabelVolume load_volume_spec(const std::string& spec) {
  if (const auto o = synth_spec(spec)) {
    auto v = io::make_synth_volume(*o).volume;
    v.source = spec;
    return v;
  }
  return io::read_label_volume(spec);
}

// The analytic junctions of a synthetic volume spec (the wedge ball has some), or nothing for files.
inline std::optional<io::Junctions> synth_junctions(const std::string& spec) {
  const auto o = synth_spec(spec);
  if (!o || o->shape != io::SynthShape::wedge_ball) return std::nullopt;
  return io::make_synth_volume(*o).junctions;
}

inline nlohmann::json junction_json(const mesh::JunctionError& e) {
  return {{"edges", e.edges}, {"spurious", e.spurious}, {"mean", e.mean}, {"max", e.max},
          {"max_whole_edge", e.max_whole_edge}};
}

}  // namespace cpmesh::bench
