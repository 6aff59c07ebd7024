// Work in a forked child (child_process.h): results, errors, deaths, and no descriptor kept from the caller.
#include <doctest/doctest.h>

#include <csignal>
#include <stdexcept>
#include <string>

#include <fcntl.h>
#include <unistd.h>

#include "mesh/child_process.h"

using namespace cpmesh;

TEST_CASE("run_in_child: the job's bytes come back; its exception becomes ours; a killed child is named") {
  CHECK(mesh::run_in_child("echo", [] { return std::string("a\0b", 3); }) == std::string("a\0b", 3));
  CHECK_THROWS_WITH(mesh::run_in_child("thrower", []() -> std::string { throw std::runtime_error("no luck"); }),
                    "no luck");
  CHECK_THROWS_WITH(mesh::run_in_child("victim", []() -> std::string { std::raise(SIGKILL); return ""; }),
                    doctest::Contains("victim died with signal 9"));
}

TEST_CASE("run_in_child: the child keeps no other descriptor, so a sibling's death is seen when it happens") {
  // Another thread's run may be between its pipe() and its close of the write end when this child is forked (16 runs
  // starting at once). A child that kept its copy of that write end would hold the sibling's pipe open after the
  // sibling died, and the sibling's caller would learn of the death only when this child ended. Stand-in: a pipe
  // open here while the child is forked.
  int fds[2];
  REQUIRE(pipe(fds) == 0);
  const std::string seen = mesh::run_in_child("fd check", [&] {
    std::string r;
    for (int fd : {0, 1, 2, fds[0], fds[1]}) r += fcntl(fd, F_GETFD) == -1 ? '-' : 'o';
    return r;
  });
  close(fds[0]);
  close(fds[1]);
  CHECK(seen == "ooo--");  // the standard streams stay; the other pipe's ends are closed
}
