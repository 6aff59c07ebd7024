// libFuzzer target: the whole reading path of a volume file, read_label_volume / read_float_volume (format sniffing
// by content, whole-file gzip, every header parser, the shared checks and sample decoding and axis reordering).
#include "fuzz_common.h"
#include "io/read_volume.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace cpmesh;
  // No extension: the format must come from the content alone.
  const std::string path = fuzz::write_input(data, size, "input");
  fuzz::accepts([&] { (void)io::read_label_volume(path); });
  fuzz::accepts([&] { (void)io::read_float_volume(path); });
  // The headerless raw fallback, with a geometry taken from the input's first byte.
  io::RawOptions raw;
  const uint8_t b = size ? data[0] : 0;
  raw.dims = {1 + (b & 3), 1 + ((b >> 2) & 3), 1 + ((b >> 4) & 1)};
  raw.type = io::ScalarType((b >> 5) & 7);
  raw.big_endian = b & 1;
  fuzz::accepts([&] { (void)io::read_label_volume(path, &raw); });
  return 0;
}
