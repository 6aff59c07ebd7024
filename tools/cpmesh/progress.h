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

// One progress line on stderr for stage `index` of `count`: "[i/n] stage ... text" while it runs, rewritten in place
// ("\033[K" clears what a longer line left), and "[i/n] stage: text" with a newline when it is done.
inline void stage_line(int index, int count, const std::string& stage, const std::string& text, bool done) {
  if (done)
    std::fprintf(stderr, "\r[%d/%d] %s: %s\033[K\n", index, count, stage.c_str(), text.c_str());
  else
    std::fprintf(stderr, "\r[%d/%d] %s ...%s%s\033[K", index, count, stage.c_str(), text.empty() ? "" : " ",
                 text.c_str());
  std::fflush(stderr);
}

class Progress {
 public:
  explicit Progress(int stages) : stages_(stages), tty_(isatty(STDERR_FILENO) != 0) {}

  template <class F>
  decltype(auto) stage(const std::string& name, F&& work) {
    ++current_;
    if (tty_) stage_line(current_, stages_, name, "", false);
    const auto t0 = std::chrono::steady_clock::now();
    struct Finish {
      Progress* p;
      std::string name;
      std::chrono::steady_clock::time_point t0;
      ~Finish() {
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        p->times_.emplace_back(name, s);
        if (p->tty_) {
          char text[64];
          std::snprintf(text, sizeof text, "%s%.2f s", std::uncaught_exceptions() ? "failed after " : "", s);
          stage_line(p->current_, p->stages_, name, text, true);
        }
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
