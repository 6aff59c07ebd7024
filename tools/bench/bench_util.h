#pragma once
// Helpers shared by the benchmarks.
#include <sys/resource.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/read_volume.h"
#include "io/synth_corpus.h"
#include "io/synth_volumes.h"
#include "mesh/quality.h"

namespace cpmesh::bench {

// Peak resident set size of this process so far, MiB.
inline double peak_rss_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_maxrss) / 1024.0;
}

// A benchmark volume: "shape:size" (cpmesh-synth's shapes), "corpus:NAME" (a volume of the realistic corpus,
// `cpmesh-synth --list`) or a volume
// file (an existing path is always a file). The synthetic volume's options, or nothing for a file; a bad shape or
// size throws, naming the spec.
inline std::optional<io::SynthOptions> synth_spec(const std::string& spec) {
  const auto colon = spec.find(':');
  if (colon == std::string::npos || spec.find('.') != std::string::npos || std::filesystem::exists(spec))
    return std::nullopt;
  try {
    if (spec.substr(0, colon) == "corpus") return io::corpus_entry(spec.substr(colon + 1)).options;
    io::SynthOptions o;
    o.shape = io::parse_synth_shape(spec.substr(0, colon));
    const std::string size = spec.substr(colon + 1);
    char* end = nullptr;
    const long long n = std::strtoll(size.c_str(), &end, 10);
    if (size.empty() || *end != '\0') throw std::invalid_argument("field 'size': expected voxels per axis, got '" + size + "'");
    o.size = n;
    io::check_synth_options(o);  // the range make_synth_volume takes
    return o;
  } catch (const std::exception& e) {
    throw std::invalid_argument("volume '" + spec + "': " + e.what());
  }
}

// Checks a spec before any run starts: a synthetic volume's shape and size, or that the file is a regular file (not
// that it reads as a volume).
inline void check_volume_spec(const std::string& spec) {
  if (!synth_spec(spec) && !std::filesystem::is_regular_file(spec))
    throw std::invalid_argument("volume '" + spec + "': no such file (or shape:size, e.g. wedge-ball:128)");
}

// A loaded benchmark volume, with the analytic junctions where it has them (the synthetic wedge ball's), made once.
struct BenchVolume {
  io::LabelVolume volume;
  std::optional<io::Junctions> junctions;
};

inline BenchVolume load_volume_spec(const std::string& spec) {
  BenchVolume out;
  if (const auto o = synth_spec(spec)) {
    auto synth = io::make_synth_volume(*o);
    out.volume = std::move(synth.volume);
    out.volume.source = spec;
    if (o->shape == io::SynthShape::wedge_ball) out.junctions = std::move(synth.junctions);
    return out;
  }
  out.volume = io::read_label_volume(spec);
  return out;
}

// Least-squares slope of log y against log x: the exponent k of y ~ x^k. NaN with fewer than two points or one x.
inline double loglog_slope(const std::vector<double>& x, const std::vector<double>& y) {
  const size_t n = std::min(x.size(), y.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (size_t i = 0; i < n; ++i) {
    const double lx = std::log(x[i]), ly = std::log(std::max(y[i], 1e-9));
    sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly;
  }
  const double d = double(n) * sxx - sx * sx;
  return n >= 2 && d > 1e-12 ? (double(n) * sxy - sx * sy) / d : std::nan("");
}

// An exponent for a table ("-" where it could not be fitted) and for JSON (null there).
inline std::string exponent_cell(double k) {
  if (std::isnan(k)) return "-";
  char cell[32];
  std::snprintf(cell, sizeof cell, "%.2f", k);
  return cell;
}
inline nlohmann::json exponent_json(double k) { return std::isnan(k) ? nlohmann::json(nullptr) : nlohmann::json(k); }

// 0.5 -> "0.5", 2 -> "2" (row labels).
inline std::string short_number(double v) {
  char s[32];
  std::snprintf(s, sizeof s, "%g", v);
  return s;
}

// One pipeline run of a scaling sweep (cpmesh-bench-pipeline --sweep-max-size): seconds per stage and step.
struct ScalingRow {
  double max_size = 0, particles = 0;
  std::map<std::string, double> seconds;
};

// The sweep's table (a row per run, a column per key) and each key's fitted exponent against the particle count,
// then one JSON line. A key missing from any row (a stage the runs skipped) is left out.
inline void print_scaling(const std::string& volume, const std::vector<ScalingRow>& rows,
                          const std::vector<std::string>& keys) {
  std::vector<std::string> present;
  for (const auto& k : keys)
    if (!rows.empty() && std::all_of(rows.begin(), rows.end(), [&](const ScalingRow& r) { return r.seconds.count(k); }))
      present.push_back(k);
  std::printf("Scaling of %s with the particle count (seconds; advection iteration: advection / iterations)\n",
              volume.c_str());
  std::printf("%8s %10s", "max size", "particles");
  for (const auto& k : present) std::printf(" %*s", int(std::max<size_t>(9, k.size())), k.c_str());
  std::printf("\n");
  std::vector<double> xs;
  for (const auto& r : rows) {
    xs.push_back(r.particles);
    std::printf("%8g %10.0f", r.max_size, r.particles);
    for (const auto& k : present) std::printf(" %*.3g", int(std::max<size_t>(9, k.size())), r.seconds.at(k));
    std::printf("\n");
  }
  std::printf("%19s", "exponent k, t ~ n^k");
  nlohmann::json exponents = nlohmann::json::object(), json_rows = nlohmann::json::array();
  for (const auto& k : present) {
    std::vector<double> ys;
    for (const auto& r : rows) ys.push_back(r.seconds.at(k));
    const double e = loglog_slope(xs, ys);
    std::printf(" %*s", int(std::max<size_t>(9, k.size())), exponent_cell(e).c_str());
    exponents[k] = exponent_json(e);
  }
  std::printf("\n");
  for (const auto& r : rows) json_rows.push_back({{"max_size", r.max_size}, {"particles", r.particles}, {"seconds", r.seconds}});
  std::printf("%s\n", nlohmann::json{{"benchmark", "pipeline_scaling"}, {"volume", volume}, {"rows", json_rows},
                                     {"exponents", exponents}}.dump().c_str());
  std::fflush(stdout);
}

inline nlohmann::json junction_json(const mesh::JunctionError& e) {
  return {{"edges", e.edges}, {"spurious", e.spurious}, {"mean", e.mean}, {"max", e.max},
          {"max_whole_edge", e.max_whole_edge}};
}

}  // namespace cpmesh::bench
