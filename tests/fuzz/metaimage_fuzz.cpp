// libFuzzer target: the metaimage header parser (parse_metaimage_header), then the shared checks and sample loading.
#include "fuzz_common.h"
#include "io/metaimage.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace cpmesh;
  (void)io::is_metaimage(std::string_view(reinterpret_cast<const char*>(data), size));
  fuzz::parse_and_load(data, size, "in.mha", [](const std::string& file, std::string_view head) {
    return io::parse_metaimage_header(file, head);
  });
  return 0;
}
