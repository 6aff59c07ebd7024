// fields::MaterialSet (material_set.h): a feature's materials as four 16-bit slots, for any material index below
// 65535; its inclusion and intersection against their definitions on sets (std::set), over random sets.
#include <doctest/doctest.h>

#include <algorithm>
#include <random>
#include <set>
#include <stdexcept>

#include "fields/closest_point_embedding.h"
#include "fields/material_set.h"

using namespace cpmesh;
using fields::MaterialSet;

TEST_CASE("a material set holds 1 to 4 materials of any index below 65535, in four slots") {
  const MaterialSet s{9000, 3, 3};
  CHECK(s.members() == std::vector<uint16_t>{3, 9000});
  CHECK(s.packed() == (9000ull | 3ull << 16 | 3ull << 32 | 3ull << 48));
  CHECK(s.has(3));
  CHECK(s.has(9000));
  CHECK_FALSE(s.has(0));
  CHECK_FALSE(s.has(MaterialSet::kNone));
  CHECK(MaterialSet().empty());
  CHECK(MaterialSet().members().empty());
  CHECK_FALSE(s.empty());
  CHECK(MaterialSet{65534}.members() == std::vector<uint16_t>{65534});
  CHECK_THROWS_AS(MaterialSet(std::vector<uint16_t>{}), std::invalid_argument);
  CHECK_THROWS_AS((MaterialSet{1, 2, 3, 4, 5}), std::invalid_argument);
  CHECK_THROWS_AS((MaterialSet{1, MaterialSet::kNone}), std::invalid_argument);
  // A feature's set: its materials, for any index.
  fields::Feature f;
  f.kind = fields::FeatureKind::triple_curve;
  f.materials = {64, 300, 1002, 0xffff};
  CHECK(f.material_set().members() == std::vector<uint16_t>{64, 300, 1002});
}

TEST_CASE("inclusion and intersection agree with sets, for ids whose halves differ in one byte or bit") {
  const uint16_t pool[] = {0, 1, 2, 0x100, 0x101, 0x7fff, 0x8000, 0x8001, 0xfffe, 255, 256, 700};
  std::mt19937 rng(5);
  auto random_set = [&] {
    std::vector<uint16_t> m;
    for (uint32_t k = 1 + rng() % 4; k > 0; --k) m.push_back(pool[rng() % std::size(pool)]);
    return MaterialSet(m);
  };
  auto as_set = [](const MaterialSet& s) {
    const auto m = s.members();
    return std::set<uint16_t>(m.begin(), m.end());
  };
  int includes = 0, empty = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const MaterialSet a = random_set(), b = random_set();
    const auto sa = as_set(a), sb = as_set(b);
    CHECK(a.includes(b) == std::includes(sa.begin(), sa.end(), sb.begin(), sb.end()));
    std::set<uint16_t> both;
    std::set_intersection(sa.begin(), sa.end(), sb.begin(), sb.end(), std::inserter(both, both.end()));
    const MaterialSet c = a.common(b);
    CHECK(as_set(c) == both);
    CHECK(c.empty() == both.empty());
    // What the tree walk's lumping asks of a node's intersection: it includes a walker's set exactly when both do.
    const MaterialSet w = random_set();
    CHECK(c.includes(w) == (a.includes(w) && b.includes(w)));
    includes += a.includes(b);
    empty += c.empty();
  }
  CHECK(includes > 500);  // the trials exercise both answers
  CHECK(empty > 500);
  CHECK(MaterialSet().includes(MaterialSet()));
  CHECK_FALSE(MaterialSet{1}.includes(MaterialSet()));
  CHECK_FALSE(MaterialSet().includes(MaterialSet{1}));
}

TEST_CASE("union_of: the members of several sets and more materials, ascending and distinct") {
  const std::vector<MaterialSet> sets = {{300, 4}, {4, 70000 % 65536}, {}};
  CHECK(fields::union_of(sets, {4, 1}) == std::vector<uint16_t>{1, 4, 300, 70000 % 65536});
  CHECK(fields::union_of(std::span<const fields::MaterialSet>{}, {}).empty());
}

TEST_CASE("material lists: any number of materials, ascending and distinct") {
  const fields::MaterialList l(std::vector<uint16_t>{1002, 3, 84, 3, 255, 7, 9});
  CHECK(l.members() == std::vector<uint16_t>{3, 7, 9, 84, 255, 1002});
  CHECK(l.has(255));
  CHECK(!l.has(4));
  const fields::MaterialList from_set = fields::MaterialSet{5, 1};
  CHECK(from_set.members() == std::vector<uint16_t>{1, 5});
  CHECK(fields::union_of(std::array{l, from_set}, {2}) == std::vector<uint16_t>{1, 2, 3, 5, 7, 9, 84, 255, 1002});
}
