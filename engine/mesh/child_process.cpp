#include "mesh/child_process.h"

#include <cerrno>
#include <csignal>
#include <cstdio>
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
    close(fds[0]);
    for (int sig : {SIGSEGV, SIGABRT, SIGBUS, SIGFPE, SIGILL}) std::signal(sig, SIG_DFL);  // no inherited crash reports
    std::string buf;
    try {
      buf = '\0' + job();
    } catch (const std::exception& e) {
      buf.assign(1, '\1');
      buf += e.what();
    }
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
  std::string buf;
  char chunk[1 << 16];
  for (;;) {
    const ssize_t r = read(fds[0], chunk, sizeof chunk);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;
    buf.append(chunk, size_t(r));
  }
  close(fds[0]);
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
