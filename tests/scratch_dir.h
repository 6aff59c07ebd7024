#pragma once
// A directory of the test process's own under the system's temporary one (cpmesh_test_<pid>/<name>), created when
// asked for and removed, with everything in it, when the process exits: a test run leaves nothing behind.
#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace cpmesh::test {

inline std::filesystem::path scratch_dir(const std::string& name) {
  struct Root {
    std::filesystem::path path =
        std::filesystem::temp_directory_path() / ("cpmesh_test_" + std::to_string(::getpid()));
    ~Root() {
      std::error_code ignored;
      std::filesystem::remove_all(path, ignored);
    }
  };
  static const Root root;
  const std::filesystem::path dir = root.path / name;
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace cpmesh::test
