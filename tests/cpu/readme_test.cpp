// The README's two set-up commands are what users and CI run: keep them true.
#include <doctest/doctest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace {
std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Lines of the README's quick-start code block that start with "bash tools/install-deps.sh".
std::vector<std::string> setup_commands(const std::string& readme) {
  std::vector<std::string> out;
  std::istringstream in(readme);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("bash tools/install-deps.sh", 0) == 0) out.push_back(line);
  return out;
}
}  // namespace

TEST_CASE("the README has exactly two set-up commands and .ci/run runs the second verbatim") {
  const auto readme = slurp(std::string(CPMESH_SOURCE_DIR) + "/README.md");
  const auto ci = slurp(std::string(CPMESH_SOURCE_DIR) + "/.ci/run");
  const auto commands = setup_commands(readme);
  REQUIRE(commands.size() == 2);
  CHECK(commands[1].find("ctest") != std::string::npos);
  CHECK(commands[0].find("build/bin/cpmesh ") != std::string::npos);
  CHECK(ci.find("\n" + commands[1] + "\n") != std::string::npos);
  // .ci/run does nothing beyond that command (comments, shell options and cd aside).
  std::istringstream in(ci);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#' || line.rfind("set ", 0) == 0 || line.rfind("cd ", 0) == 0) continue;
    CHECK(line == commands[1]);
  }
}

TEST_CASE("the README's demo reads a volume that ships in assets/") {
  const auto commands = setup_commands(slurp(std::string(CPMESH_SOURCE_DIR) + "/README.md"));
  REQUIRE(commands.size() == 2);
  const auto at = commands[0].find("assets/");
  REQUIRE(at != std::string::npos);
  const auto path = commands[0].substr(at, commands[0].find(' ', at) - at);
  CHECK(std::ifstream(std::string(CPMESH_SOURCE_DIR) + "/" + path).good());
}
