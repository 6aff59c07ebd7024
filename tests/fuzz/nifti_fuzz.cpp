// libFuzzer target: the nifti header parser (parse_nifti_header), then the shared checks and sample loading.
#include "fuzz_common.h"
#include "io/nifti.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace cpmesh;
  (void)io::is_nifti(std::string_view(reinterpret_cast<const char*>(data), size));
  fuzz::parse_and_load(data, size, "in.nii", [](const std::string& file, std::string_view head) {
    return io::parse_nifti_header(file, head);
  });
  return 0;
}
