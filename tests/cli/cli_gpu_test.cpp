// The cpmesh binary: help, version, device listing and choice, selftest, errors and exit codes.
#include <doctest/doctest.h>

#include "cli/run_tool.h"

using cpmesh::test::contains;
using cpmesh::test::run_tool;

TEST_CASE("--version and --help") {
  const auto v = run_tool("cpmesh --version");
  CHECK(v.exit_code == 0);
  CHECK(contains(v.output, "cpmesh 0."));
  const auto h = run_tool("cpmesh --help");
  CHECK(h.exit_code == 0);
  for (const char* s : {"devices", "selftest", "--device", "--profile", "--version"}) CHECK(contains(h.output, s));
  const auto sh = run_tool("cpmesh selftest --help");
  CHECK(sh.exit_code == 0);
  CHECK(contains(sh.output, "--size"));
}

TEST_CASE("usage errors exit non-zero with a message") {
  const auto none = run_tool("cpmesh");
  CHECK(none.exit_code != 0);
  CHECK(contains(none.output, "subcommand"));
  const auto bogus = run_tool("cpmesh frobnicate");
  CHECK(bogus.exit_code != 0);
  const auto bad_size = run_tool("cpmesh selftest --size -5");
  CHECK(bad_size.exit_code != 0);
}

TEST_CASE("devices lists every device with its limits and marks the chosen one") {
  const auto r = run_tool("cpmesh devices");
  REQUIRE(r.exit_code == 0);
  for (const char* s : {"max storage buffer range", "shared memory", "subgroup size", "float32 atomic add",
                        "memory heap 0", "[selected]"})
    CHECK(contains(r.output, s));
  const auto j = run_tool("cpmesh devices --json");
  CHECK(j.exit_code == 0);
  CHECK(contains(j.output, "\"max_storage_buffer_range\""));
  CHECK(contains(j.output, "\"selected\": 0") == contains(r.output, "* 0:"));
}

TEST_CASE("--device and CPMESH_DEVICE choose a device; a bad choice is a clear error") {
  const auto list = run_tool("cpmesh devices");
  if (contains(list.output, "llvmpipe")) {
    const auto by_name = run_tool("cpmesh --device LLVMPIPE devices");
    CHECK(by_name.exit_code == 0);
    CHECK(contains(by_name.output, "llvmpipe"));
    const auto by_env = run_tool("cpmesh selftest -n 3000", "CPMESH_DEVICE=llvmpipe");
    CHECK(by_env.exit_code == 0);
    CHECK(contains(by_env.output, "on llvmpipe"));
  }
  const auto bad = run_tool("cpmesh --device no-such-gpu selftest -n 10");
  CHECK(bad.exit_code == 1);
  CHECK(contains(bad.output, "--device 'no-such-gpu' matches no Vulkan device"));
  const auto bad_env = run_tool("cpmesh selftest -n 10", "CPMESH_DEVICE=99");
  CHECK(bad_env.exit_code == 1);
  CHECK(contains(bad_env.output, "CPMESH_DEVICE '99'"));
}

TEST_CASE("selftest passes with validation and prints a profile") {
  const auto r = run_tool("cpmesh selftest -n 70000 --validation --profile");
  CHECK(r.exit_code == 0);
  CHECK(contains(r.output, "all building blocks agree"));
  CHECK(contains(r.output, "radix_sort u64"));
  CHECK(!contains(r.output, "FAIL"));
  if (contains(r.output, "validation errors:")) CHECK(contains(r.output, "validation errors: 0"));
  CHECK(contains(r.output, "radix_scatter_u32"));  // the profile table
}
