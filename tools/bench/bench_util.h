#pragma once
// Helpers shared by the benchmarks.
#include <sys/resource.h>

namespace cpmesh::bench {

// Peak resident set size of this process so far, MiB.
inline double peak_rss_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_maxrss) / 1024.0;
}

}  // namespace cpmesh::bench
