// The well-composed repair of label maps (mesh/well_composed.h): edge-only and corner-only pairs of a label are
// joined across a face, the thin label of a checkerboard is the one joined, islands of one voxel and small labels
// give nothing, and the corpus volumes come out with no critical configuration at a small cost in voxels.
#include <doctest/doctest.h>

#include <cmath>
#include <map>

#include "io/synth_corpus.h"
#include "label_maps.h"
#include "mesh/small_labels.h"
#include "mesh/well_composed.h"

using namespace cpmesh;
using cpmesh::test::block;
using cpmesh::test::components;

namespace {

void set(io::LabelVolume& v, int64_t i, int64_t j, int64_t k, uint16_t l) { v.labels[v.index(i, j, k)] = l; }
uint16_t at(const io::LabelVolume& v, int64_t i, int64_t j, int64_t k) { return v.labels[v.index(i, j, k)]; }

}  // namespace

TEST_CASE("a checkerboard square: the label with fewer voxels around it is joined, from the common one") {
  io::LabelVolume v = block(6, 1);
  set(v, 2, 2, 2, 2);
  set(v, 3, 3, 2, 2);  // 2 and 2 touch along an edge, so do 1 and 1 across it
  CHECK(mesh::critical_configurations(v) == 2);
  const auto rep = mesh::make_well_composed(v, mesh::kProtectedLabelVoxels, 1.0);
  CHECK(rep.critical_before == 2);
  CHECK(rep.critical_left == 0);
  CHECK(mesh::critical_configurations(v) == 0);
  CHECK(rep.voxels_changed == 1);
  CHECK(at(v, 3, 2, 2) + at(v, 2, 3, 2) == 3);  // one of the two 1s became 2
  CHECK(components(v, 2) == std::vector<int64_t>{3});
  REQUIRE(rep.labels.size() == 2);
  CHECK(rep.labels[0].label == 1);
  CHECK(rep.labels[0].lost == 1);
  CHECK(rep.labels[0].gained == 0);
  CHECK(rep.labels[1].label == 2);
  CHECK(rep.labels[1].gained == 1);
}

TEST_CASE("a one-voxel sheet stepping diagonally stays whole, and the label around it keeps its two sides") {
  io::LabelVolume v = block(8, 1);
  for (int64_t j = 0; j < 8; ++j)
    for (int64_t k = 0; k < 8; ++k) set(v, j < 4 ? 3 : 4, j, k, 5);
  REQUIRE(components(v, 5) == std::vector<int64_t>{32, 32});
  const io::LabelVolume before_sheet = v;  // face-connected only along the step's edge
  REQUIRE(components(v, 1).size() == 2);                      // its two sides touch along the same edge
  const auto rep = mesh::make_well_composed(v, mesh::kProtectedLabelVoxels, 1.0);
  CHECK(rep.critical_left == 0);
  CHECK(rep.voxels_changed == 8);  // one per voxel along the step
  CHECK(components(v, 5) == std::vector<int64_t>{32 + 32 + 8});
  CHECK(components(v, 1).size() == 2);
  // At the default cap, 1% of the sheet's 64 voxels (rounded up), it gains one voxel and the other steps stay.
  io::LabelVolume capped = before_sheet;
  const auto one = mesh::make_well_composed(capped);
  CHECK(one.voxels_changed == 1);
  CHECK(one.critical_left == one.critical_before - 2);
}

TEST_CASE("a corner-only pair takes two voxels, one per pass") {
  io::LabelVolume v = block(6, 1);
  set(v, 2, 2, 2, 2);
  set(v, 3, 3, 3, 2);
  CHECK(mesh::critical_configurations(v) == 1);
  const auto rep = mesh::make_well_composed(v, mesh::kProtectedLabelVoxels, 1.0);
  CHECK(rep.critical_left == 0);
  CHECK(rep.voxels_changed == 2);
  CHECK(rep.passes >= 2);
  CHECK(components(v, 2) == std::vector<int64_t>{4});
}

TEST_CASE("islands of one voxel and labels under the protected size give no voxel; what is left is counted") {
  io::LabelVolume v = block(6, 1);
  set(v, 2, 2, 2, 2);
  set(v, 3, 3, 2, 2);
  set(v, 3, 2, 2, 3);  // the two other voxels of the square are islands of one voxel of labels 3 and 4
  set(v, 2, 3, 2, 4);
  const io::LabelVolume before = v;
  const auto rep = mesh::make_well_composed(v);
  CHECK(rep.critical_before == 1);
  CHECK(rep.critical_left == 1);
  CHECK(rep.voxels_changed == 0);
  CHECK(v.labels == before.labels);
  // Label 1 is the large one here, yet under a protected size of more voxels than it has it gives none either.
  io::LabelVolume w = block(6, 1);
  set(w, 2, 2, 2, 2);
  set(w, 3, 3, 3, 2);
  CHECK(mesh::make_well_composed(w, 1000).voxels_changed == 0);
}

TEST_CASE("a well-composed label map is left as it is") {
  io::LabelVolume v = block(8, 1);
  for (int64_t i = 4; i < 8; ++i)
    for (int64_t j = 0; j < 8; ++j)
      for (int64_t k = 0; k < 8; ++k) set(v, i, j, k, 2);
  const io::LabelVolume before = v;
  const auto rep = mesh::make_well_composed(v);
  CHECK(rep.applied);
  CHECK(rep.critical_before == 0);
  CHECK(rep.voxels_changed == 0);
  CHECK(rep.passes == 0);
  CHECK(v.labels == before.labels);
}

TEST_CASE("corpus: the critical configurations go, each label changing by at most 1% of its voxels, once") {
  // thin-48's one-voxel CSF shell steps diagonally at 11% of its voxels: most of its steps stay (the share cap).
  for (const char* name : {"noisy-48", "thin-48", "parcellation-48", "organs-64", "islands-48"}) {
    CAPTURE(std::string(name));
    io::LabelVolume v = io::make_synth_volume(io::corpus_entry(name).options).volume;
    const mesh::LabelCensus before = mesh::label_census(v);
    const auto rep = mesh::make_well_composed(v);
    CHECK(rep.critical_left == mesh::critical_configurations(v));
    if (std::string(name) != "thin-48") CHECK(rep.critical_left * 20 <= rep.critical_before);
    CHECK(rep.critical_left < rep.critical_before);
    // Each label's voxel count moves by what the report says, within the cap, and no label vanishes.
    const mesh::LabelCensus after = mesh::label_census(v);
    std::map<uint16_t, mesh::LabelChange> change;
    for (const auto& c : rep.labels) change[c.label] = c;
    for (size_t l = 0; l < before.size(); ++l) {
      const auto c = change.count(uint16_t(l)) ? change[uint16_t(l)] : mesh::LabelChange{};
      CHECK(after[l] - before[l] == c.gained - c.lost);
      const auto cap = int64_t(std::ceil(mesh::kLabelChangeShare * double(before[l])));
      CHECK(c.gained <= cap);
      CHECK(c.lost <= cap);
      if (before[l] > 0) CHECK(after[l] > 0);
    }
  }
}
