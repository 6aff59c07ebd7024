#pragma once
// Shared helpers of the libFuzzer targets (tests/fuzz/*_fuzz.cpp). Built with clang only, outside the g++ build.
//
// Contract checked by every target: for any input bytes the readers either return or throw an exception derived from
// std::exception (cpmesh::io::Error for malformed input). Crashes, sanitizer reports, hangs and allocations above the
// fuzzer's -malloc_limit_mb are bugs.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "io/volume_layout.h"

namespace cpmesh::fuzz {

// A private directory for this process (under $TMPDIR, which the CTest driver points at its own scratch directory),
// so detached-header data file names ("data file: x.raw") resolve next to the input and never collide between runs.
inline const std::filesystem::path& scratch_dir() {
  static const std::filesystem::path dir = [] {
    const char* base = std::getenv("TMPDIR");
    std::string tmpl = std::string(base && *base ? base : "/tmp") + "/cpmesh-fuzz-XXXXXX";
    if (!::mkdtemp(tmpl.data())) std::abort();
    return std::filesystem::path(tmpl);
  }();
  return dir;
}

// Writes the input to "<scratch>/<name>" (rewritten for every input) and returns its path.
inline std::string write_input(const uint8_t* data, size_t size, const std::string& name) {
  const std::string path = (scratch_dir() / name).string();
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
  out.close();
  if (!out) std::abort();
  return path;
}

// Runs `f`; std::exception is the expected rejection of malformed input, anything else propagates (and crashes).
template <typename F>
bool accepts(F&& f) {
  try {
    f();
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

// A header parser's result, pushed through the checks and the sample loading that follow every parse in
// read_label_volume / read_float_volume. The input is written to a file named `name` first, so attached data
// (and data_file names relative to the header) resolve as they would for a real file.
template <typename Parse>
void parse_and_load(const uint8_t* data, size_t size, const std::string& name, Parse&& parse) {
  const std::string_view head(reinterpret_cast<const char*>(data), size);
  io::VolumeLayout layout;
  // 1. The header parser alone, from memory (no file access).
  if (!accepts([&] { layout = parse("fuzz-input", head); })) return;
  // 2. The shared checks and the data path, from a file holding the same bytes.
  const std::string path = write_input(data, size, name);
  if (!accepts([&] { layout = parse(path, head); })) return;
  accepts([&] { (void)io::load_label_layout(layout, nullptr); });
  accepts([&] { (void)io::load_float_layout(layout, nullptr); });
}

}  // namespace cpmesh::fuzz
