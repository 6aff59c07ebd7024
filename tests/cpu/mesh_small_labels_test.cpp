// Labels under --min-label-voxels (mesh/small_labels.h): each joins the label it touches most, is reported with its
// voxel count, and a small label does not join another small one while a kept one touches it.
#include <doctest/doctest.h>

#include "label_maps.h"
#include "mesh/small_labels.h"

using namespace cpmesh;
using cpmesh::test::block;

TEST_CASE("small labels join the label they touch most, and are listed") {
  io::LabelVolume v = block(8, 1);
  for (int64_t i = 4; i < 8; ++i)
    for (int64_t j = 0; j < 8; ++j)
      for (int64_t k = 0; k < 8; ++k) v.labels[v.index(i, j, k)] = 2;  // half 1, half 2
  v.labels[v.index(1, 1, 1)] = 7;                                     // one voxel inside 1
  v.labels[v.index(3, 5, 5)] = 9, v.labels[v.index(2, 5, 5)] = 9;     // two voxels: 1 on five faces, 2 on one, 9 itself
  v.labels[v.index(4, 2, 2)] = 8;                                     // inside 2 at the border: 2 five times, 1 once
  v.labels[v.index(0, 7, 7)] = 5;                                     // at the corner: the outside on three faces, 1 on three
  const auto dropped = mesh::small_labels(v, 8);
  REQUIRE(dropped.size() == 4);
  CHECK(dropped[0].label == 5);
  CHECK(dropped[0].merged_into == 0);  // ties go to the lower label: the outside
  CHECK(dropped[1].label == 7);
  CHECK(dropped[1].voxels == 1);
  CHECK(dropped[1].merged_into == 1);
  CHECK(dropped[2].label == 8);
  CHECK(dropped[2].merged_into == 2);
  CHECK(dropped[3].label == 9);
  CHECK(dropped[3].voxels == 2);
  CHECK(dropped[3].merged_into == 1);
  const auto merged = mesh::merge_labels(v, dropped);
  CHECK(merged.labels[merged.index(1, 1, 1)] == 1);
  CHECK(merged.labels[merged.index(4, 2, 2)] == 2);
  // The census merged the same way counts the merged volume (the material limit reads it).
  const mesh::LabelCensus census = mesh::merge_labels(mesh::label_census(v), dropped);
  CHECK(census == mesh::label_census(merged));
  CHECK(census[0] == 1);  // label 5 joined the outside
  CHECK(census[7] == 0);
  CHECK(mesh::small_labels(v, 1).empty());
  CHECK(mesh::small_labels(v, 0).empty());
  CHECK(mesh::small_labels(v, 2).size() == 3);  // 9 has two voxels: kept
}

TEST_CASE("a small label beside another small one joins the kept label") {
  io::LabelVolume v = block(6, 1);
  v.labels[v.index(2, 2, 2)] = 3;
  v.labels[v.index(3, 2, 2)] = 4;  // 3 and 4 touch each other once, 1 five times each
  const auto dropped = mesh::small_labels(v, 8);
  REQUIRE(dropped.size() == 2);
  CHECK(dropped[0].merged_into == 1);
  CHECK(dropped[1].merged_into == 1);
}
