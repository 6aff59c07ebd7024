#pragma once
// Helpers shared by the benchmarks.
#include <sys/resource.h>

#include <string>

#include "io/read_volume.h"
#include "io/synth_volumes.h"

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

}  // namespace cpmesh::bench
