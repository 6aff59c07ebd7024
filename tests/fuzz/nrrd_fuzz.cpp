// libFuzzer target: the nrrd header parser (parse_nrrd_header), then the shared checks and sample loading.
#include "fuzz_common.h"
#include "io/nrrd.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace cpmesh;
  (void)io::is_nrrd(std::string_view(reinterpret_cast<const char*>(data), size));
  fuzz::parse_and_load(data, size, "in.nrrd", [](const std::string& file, std::string_view head) {
    return io::parse_nrrd_header(file, head);
  });
  return 0;
}
