// The add/delete rounds' steady rule (particles::SteadyRule) on round counts measured in real runs.
#include <doctest/doctest.h>

#include <array>
#include <vector>

#include "particles/population.h"

using cpmesh::particles::PopulationOptions;
using cpmesh::particles::SteadyRule;

namespace {
struct Round {
  uint32_t added, deleted, n;  // n: the population the round's check measured
};

// The first round after which the rule says steady (1-based), or 0.
int steady_after(const std::vector<Round>& rounds, const PopulationOptions& options = {}) {
  SteadyRule rule(options);
  for (size_t i = 0; i < rounds.size(); ++i) {
    rule.after_round(rounds[i].added, rounds[i].deleted, rounds[i].n);
    if (rule.steady()) return int(i) + 1;
  }
  return 0;
}
}  // namespace

TEST_CASE("steady rule: a churn that swings the count up and down ends on average, a trend does not") {
  // 32^3 shells, seed 1 (cpmesh particles): about a tenth of the particles deleted and re-added every round; never
  // two rounds running balanced within 1% of n, and the rounds ran to the limit of 20 before the window.
  const std::vector<Round> shells = {{2709, 13265, 45274}, {2972, 5892, 34718}, {2743, 4990, 31798},
                                     {3173, 2965, 29551},  {2878, 3856, 29759}, {2957, 3135, 28781},
                                     {3358, 2336, 28603},  {2874, 3948, 29625}, {3005, 2915, 28551}};
  // Rounds 4-7 sum to +74 particles, within 4 x 1% of n; rounds 3-6 to -3,195.
  CHECK(steady_after(shells) == 7);
  PopulationOptions no_window;
  no_window.steady_window = 0;
  CHECK(steady_after(shells, no_window) == 0);  // the rule before the window

  // 64^3 wedge ball: the count falls 18, 17, 17, 9, 5 (n about 1,050): steady by the two balanced rounds 4 and 5,
  // not by the window (rounds 1-4 fall by 61 and rounds 2-5 by 48, more than 4 x 1% of n).
  const std::vector<Round> wedge = {{0, 18, 1075}, {0, 17, 1057}, {0, 17, 1040}, {0, 9, 1023}, {0, 5, 1014}};
  CHECK(steady_after(wedge) == 5);
  CHECK(steady_after(wedge, no_window) == 5);

  // A steady trend (1.7-2.4% of n every round) is never steady, however long.
  std::vector<Round> trend;
  for (uint32_t r = 0; r < 20; ++r) trend.push_back({1000, 1500, 30000 - 500 * r});
  CHECK(steady_after(trend) == 0);

  // A negligible change (at most 0.1% of n added and deleted together) is steady at once.
  CHECK(steady_after({{2000, 4000, 30000}, {10, 15, 28000}}) == 2);
  CHECK(steady_after({{2000, 4000, 30000}, {20, 15, 28000}}) == 0);
}
