// libFuzzer target: the inrimage header parser (parse_inrimage_header), then the shared checks and sample loading.
#include "fuzz_common.h"
#include "io/inrimage.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace cpmesh;
  (void)io::is_inrimage(std::string_view(reinterpret_cast<const char*>(data), size));
  fuzz::parse_and_load(data, size, "in.inr", [](const std::string& file, std::string_view head) {
    return io::parse_inrimage_header(file, head);
  });
  return 0;
}
