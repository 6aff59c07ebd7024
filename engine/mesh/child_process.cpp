#include "mesh/child_process.h"

#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <algorithm>
#include <exception>
#include <stdexcept>

#include <sys/wait.h>
#include <unistd.h>

namespace cpmesh::mesh {

std::string run_in_child(const std::string& what, const std::function<std::string()>& job) {
  int fds[2];
  if (pipe(fds) != 0) throw std::runtime_error(what + ": cannot make a pipe: " + std::strerror(errno));
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]);
    close(fds[1]);
    throw std::runtime_error(what + ": cannot fork: " + std::strerror(errno));
  }
  if (pid == 0) {  // the child: run, send, leave without destructors or atexit handlers
    // Keep only the standard streams and this pipe's write end: a copy of a sibling's write end (another thread's
    // child) would keep that pipe open after its child died, and its parent would wait for this child to end before
    // it could tell.
    const auto mine = unsigned(fds[1]);
    const bool closed = (mine <= 3 || close_range(3, mine - 1, 0) == 0) && close_range(mine + 1, ~0u, 0) == 0;
    if (!closed)  // a kernel without close_range
      for (unsigned fd = 3; fd < 4096; ++fd)
        if (fd != mine) close(int(fd));
    for (int sig : {SIGSEGV, SIGABRT, SIGBUS, SIGFPE, SIGILL}) std::signal(sig, SIG_DFL);  // no inherited crash reports
    std::string buf(sizeof(uint64_t), '\0');  // the length first (see the parent's read)
    try {
      buf += '\0' + job();
    } catch (const std::exception& e) {
      buf += '\1';
      buf += e.what();
    }
    const uint64_t length = buf.size() - sizeof(uint64_t);
    std::memcpy(buf.data(), &length, sizeof length);
    for (size_t at = 0; at < buf.size();) {
      const ssize_t w = write(fds[1], buf.data() + at, buf.size() - at);
      if (w <= 0) {
        if (w < 0 && errno == EINTR) continue;
        _exit(3);
      }
      at += size_t(w);
    }
    _exit(0);
  }
  close(fds[1]);
  // Read the announced length, not to the end of the pipe: a child forked meanwhile by another thread held a copy of
  // this pipe's write end until it exited (before children closed what they inherit, all of a volume mesh's TetGen
  // runs ended at once, and their sliver passes waited for the slowest run); the length does not depend on that.
  std::string buf;
  uint64_t length = UINT64_MAX;
  char chunk[1 << 16];
  for (;;) {
    const size_t want = buf.size() < sizeof length ? sizeof length - buf.size()
                                                   : std::min<uint64_t>(sizeof chunk, length + sizeof length - buf.size());
    if (want == 0) break;
    const ssize_t r = read(fds[0], chunk, want);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;
    buf.append(chunk, size_t(r));
    if (length == UINT64_MAX && buf.size() >= sizeof length) std::memcpy(&length, buf.data(), sizeof length);
  }
  close(fds[0]);
  if (length == UINT64_MAX || buf.size() != length + sizeof length) buf.clear();  // ended early: no result
  else buf.erase(0, sizeof length);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFSIGNALED(status))
    throw std::runtime_error(what + " died with signal " + std::to_string(WTERMSIG(status)) + " (" +
                             strsignal(WTERMSIG(status)) + "); TetGen does so when it gives up on its input, e.g. "
                             "when input facets intersect");
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || buf.empty()) throw std::runtime_error(what + " ended without a result");
  if (buf[0] == '\1') throw std::runtime_error(buf.substr(1));
  return buf.substr(1);
}

}  // namespace cpmesh::mesh
