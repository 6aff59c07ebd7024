// group_by_key (grouped.h) against a serial reference: every (key, item) pair, sorted by key then item.
#include <doctest/doctest.h>

#include <algorithm>
#include <random>
#include <utility>
#include <vector>

#include <tbb/global_control.h>

#include "mesh/elements_around.h"
#include "mesh/grouped.h"

using namespace cpmesh::mesh;

namespace {

// Item i's keys: between 0 and 5 of them, drawn at random, repeats allowed.
std::vector<std::vector<uint32_t>> random_keys(size_t keys, size_t items, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<std::vector<uint32_t>> out(items);
  for (auto& ks : out) {
    const size_t n = rng() % 6;
    for (size_t j = 0; j < n; ++j) ks.push_back(uint32_t(rng() % keys));
  }
  return out;
}

void check_against_serial(size_t keys, const std::vector<std::vector<uint32_t>>& of) {
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  for (uint32_t i = 0; i < of.size(); ++i)
    for (uint32_t k : of[i]) pairs.push_back({k, i});
  std::sort(pairs.begin(), pairs.end());
  const Grouped g = group_by_key(keys, of.size(), [&](size_t i, auto&& add) {
    for (uint32_t k : of[i]) add(k);
  });
  REQUIRE(g.begin.size() == keys + 1);
  REQUIRE(g.list.size() == pairs.size());
  CHECK(g.begin[0] == 0);
  CHECK(g.begin[keys] == pairs.size());
  size_t bad = 0, e = 0;
  for (size_t k = 0; k < keys; ++k)
    for (uint32_t item : g[k]) bad += pairs[e++] != std::pair{uint32_t(k), item};
  CHECK(e == pairs.size());
  CHECK(bad == 0);
}

}  // namespace

TEST_CASE("group_by_key lists each key's items in ascending order, repeats kept, on 1 and 8 threads") {
  for (int threads : {1, 8}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
    CAPTURE(threads);
    // Fewer keys than one bucket's width, exactly 2048 (one key per bucket), and many keys per bucket (including a
    // last bucket only partly used); few items (one chunk) and many (several chunks).
    for (size_t keys : {size_t(1), size_t(7), size_t(2048), size_t(2049), size_t(100'003)})
      for (size_t items : {size_t(0), size_t(5), size_t(50'000)}) {
        CAPTURE(keys);
        CAPTURE(items);
        check_against_serial(keys, random_keys(keys, items, uint32_t(keys * 31 + items)));
      }
  }
  const Grouped none = group_by_key(0, 0, [](size_t, auto&&) {});
  CHECK(none.begin.size() == 1);
  CHECK(none.list.empty());
}

TEST_CASE("ElementsAround: the tets around each vertex, ascending, and its edits") {
  const std::vector<std::array<uint32_t, 4>> tets = {{0, 1, 2, 3}, {1, 2, 3, 4}, {4, 5, 6, 0}, {3, 4, 5, 6}};
  ElementsAround<4> around(8, tets);
  auto list = [&](uint32_t v) { return std::vector<uint32_t>(around[v].begin(), around[v].end()); };
  CHECK(list(0) == std::vector<uint32_t>{0, 2});
  CHECK(list(3) == std::vector<uint32_t>{0, 1, 3});
  CHECK(list(4) == std::vector<uint32_t>{1, 2, 3});
  CHECK(list(7).empty());
  CHECK(around[9].empty());  // past the table: a vertex added since
  around.remove(3, 1);
  around.add(3, 9);
  around.add(9, 9);
  CHECK(list(3) == std::vector<uint32_t>{0, 3, 9});
  CHECK(list(9) == std::vector<uint32_t>{9});
}
