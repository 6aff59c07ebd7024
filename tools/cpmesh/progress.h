#pragma once
// One progress line per pipeline stage on a terminal (stderr), nothing when stderr is not a terminal; the stage
// times are kept for the summary table either way.
#include <unistd.h>

#include <chrono>
#include <exception>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

namespace cpmesh::cli {

class Progress {
 public:
  explicit Progress(int stages) : stages_(stages), tty_(isatty(STDERR_FILENO) != 0) {}

  template <class F>
  decltype(auto) stage(const std::string& name, F&& work) {
    ++current_;
    if (tty_) std::fprintf(stderr, "[%d/%d] %s ...", current_, stages_, name.c_str());
    const auto t0 = std::chrono::steady_clock::now();
    struct Finish {
      Progress* p;
      std::string name;
      std::chrono::steady_clock::time_point t0;
      ~Finish() {
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        p->times_.emplace_back(name, s);
        if (p->tty_)
          std::fprintf(stderr, "\r[%d/%d] %s: %s %.2f s\n", p->current_, p->stages_, name.c_str(),
                       std::uncaught_exceptions() ? "failed after" : "", s);
      }
    } finish{this, name, t0};
    return work();
  }
  const std::vector<std::pair<std::string, double>>& times() const { return times_; }

 private:
  int stages_;
  int current_ = 0;
  bool tty_;
  std::vector<std::pair<std::string, double>> times_;
};

}  // namespace cpmesh::cli
