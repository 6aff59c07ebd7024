// Host arrays filled by every thread (host/host_array.h), disjoint sets joined by every thread (host/disjoint_sets.h),
// and the fields stage built on them: the same bits on one thread as on many.
#include <doctest/doctest.h>

#include <cstring>
#include <numeric>
#include <random>

#include <tbb/parallel_for.h>

#include <tbb/global_control.h>

#include "fields/fields_stage.h"
#include "host/disjoint_sets.h"
#include "host/host_array.h"
#include "fields_volumes.h"

using namespace cpmesh;
using namespace cpmesh::fields;

TEST_CASE("filled, copy_into and collect_in_order give what one loop gives, on 1 and 8 threads") {
  for (const int threads : {1, 8}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
    for (const size_t n : {size_t(0), size_t(1), size_t(16383), size_t(16384), size_t(100003)}) {
      const HostArray<double> a = filled(n, 2.5);
      REQUIRE(a.size() == n);
      CHECK(std::count(a.begin(), a.end(), 2.5) == ptrdiff_t(n));
      HostArray<uint32_t> from(n), to(7, 9u);
      std::iota(from.begin(), from.end(), 3u);
      copy_into(to, from);
      CHECK(to == from);
      // Layer k gives k % 3 items (k, 0), (k, 1), ...: some layers give none.
      const int layers = int(n % 1000);
      const auto all = collect_in_order<std::pair<int, int>>(layers, [](int k, auto& out) {
        for (int i = 0; i < k % 3; ++i) out.emplace_back(k, i);
      });
      std::vector<std::pair<int, int>> want;
      for (int k = 0; k < layers; ++k)
        for (int i = 0; i < k % 3; ++i) want.emplace_back(k, i);
      CHECK(all == want);
    }
  }
  CHECK(collect_in_order<int>(-1, [](int, auto&) { FAIL("no layer to visit"); }).empty());
}

TEST_CASE("disjoint sets joined on 8 threads: the sets of a serial union-find, each rooted at its smallest element") {
  // Chains and random pairs over 200000 elements: many joins race on the same roots.
  const uint32_t n = 200000;
  std::mt19937 rng(7);
  std::vector<std::pair<uint32_t, uint32_t>> joins;
  for (uint32_t i = 0; i + 1 < n; i += 3) joins.push_back({i + 1, i});  // chains of two joins per three elements
  for (int k = 0; k < 60000; ++k) joins.push_back({uint32_t(rng() % n), uint32_t(rng() % n)});
  // Reference: plain union-find, then the smallest element of each set.
  std::vector<uint32_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x];
    return x;
  };
  for (const auto& [a, b] : joins) parent[find(a)] = find(b);
  std::vector<uint32_t> smallest(n, UINT32_MAX);
  for (uint32_t x = 0; x < n; ++x) smallest[find(x)] = std::min(smallest[find(x)], x);
  for (const int threads : {1, 8}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
    DisjointSets sets(n);
    REQUIRE(sets.size() == n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, joins.size(), 64), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t j = r.begin(); j != r.end(); ++j) sets.join(joins[j].first, joins[j].second);
    });
    size_t wrong = 0;
    for (uint32_t x = 0; x < n; ++x) wrong += sets.find(x) != smallest[find(x)];
    CHECK(wrong == 0);
  }
}

TEST_CASE("the fields stage does not depend on the thread count: wedge ball, thin parts, junctions") {
  // The 40^3 wedge ball has thin parts where its wedges meet the axis (protected from tightening, and thin enough to
  // limit h), triple curves, quadruple points and junction offsets, so every parallel step of the indicator fields,
  // the embedding and the sizing field runs. (The head phantom has more thin layers, but its failed Newton points
  // make even 24^3 take 40 s here.)
  const auto wb = test::make_volume(io::SynthShape::wedge_ball, 40);
  auto build = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
    return build_fields(wb.grid, wb.labels.data());
  };
  const FieldsResult one = build(1), many = build(8);
  REQUIRE(one.fields.fields.size() == many.fields.fields.size());
  CHECK(one.fields.protected_voxels > 0);
  CHECK(one.fields.protected_voxels == many.fields.protected_voxels);
  CHECK(one.fields.tightened_voxels == many.fields.tightened_voxels);
  CHECK(one.fields.voxel_counts == many.fields.voxel_counts);
  REQUIRE(!one.fields.junction_offsets.empty());
  const glm::ivec3 d = wb.grid.dims;
  size_t differ = 0, allocated = 0;
  for (size_t m = 0; m < one.fields.fields.size(); ++m) {
    allocated += one.fields.fields[m].allocated_bricks();
    CHECK(one.fields.fields[m].allocated_bricks() == many.fields.fields[m].allocated_bricks());
    for (int k = 0; k < d.z; ++k)
      for (int j = 0; j < d.y; ++j)
        for (int i = 0; i < d.x; ++i) {
          differ += one.fields.fields[m].at(i, j, k) != many.fields.fields[m].at(i, j, k);
          differ += one.fields.junction_offsets[m].at(i, j, k) != many.fields.junction_offsets[m].at(i, j, k);
        }
  }
  CHECK(allocated > 0);
  CHECK(differ == 0);
  REQUIRE(one.embedding.fine.size() == many.embedding.fine.size());
  size_t fine_differ = 0;  // closest points and h
  for (size_t i = 0; i < one.embedding.fine.size(); ++i)
    fine_differ += std::memcmp(&one.embedding.fine[i], &many.embedding.fine[i], sizeof(glm::vec4)) != 0;
  CHECK(fine_differ == 0);
  CHECK(one.embedding.keys == many.embedding.keys);
  CHECK(one.embedding.blocks == many.embedding.blocks);
  CHECK(one.embedding.features.size() == many.embedding.features.size());
  CHECK(!one.embedding.quadruple_points.empty());
  CHECK(one.report.sizing.h_min == many.report.sizing.h_min);
  CHECK(one.report.sizing.h_max == many.report.sizing.h_max);
  CHECK(one.report.sizing.thickness_limited > 0);  // the walk along the normals found thin parts
  CHECK(one.report.sizing.thickness_limited == many.report.sizing.thickness_limited);
  CHECK(one.report.sizing.curvature_limited == many.report.sizing.curvature_limited);
  CHECK(one.report.sizing.clamped == many.report.sizing.clamped);
  CHECK(one.report.curve_smoothing.moved_points == many.report.curve_smoothing.moved_points);
}
