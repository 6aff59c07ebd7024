// The synthetic generator and `cpmesh info`'s summary: the wedge ball has the labels and 6-neighbour sets its
// construction implies, its analytic quadruple points and triple curves lie where their materials meet, and the
// bundled asset is exactly the generator's output.
#include <doctest/doctest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>

#include <nlohmann/json.hpp>

#include "io/read_volume.h"
#include "io/synth_volumes.h"
#include "io/volume_info.h"

using namespace cpmesh::io;

namespace {

// Labels of the voxels within `radius` voxels of a physical point.
std::set<uint16_t> labels_near(const LabelVolume& v, const std::array<double, 3>& p, double radius) {
  std::set<uint16_t> out;
  for (int64_t k = 0; k < v.dims[2]; ++k)
    for (int64_t j = 0; j < v.dims[1]; ++j)
      for (int64_t i = 0; i < v.dims[0]; ++i) {
        const auto q = v.position(i, j, k);
        double d2 = 0;
        for (int a = 0; a < 3; ++a) d2 += (q[a] - p[a]) * (q[a] - p[a]) / (v.spacing[a] * v.spacing[a]);
        if (d2 <= radius * radius) out.insert(v.labels[v.index(i, j, k)]);
      }
  return out;
}

// Expected 6-neighbours from the construction: the background touches the three wedges (the inner ball stays inside
// the outer one); the wedges touch each other, the background and the inner ball; the inner ball touches the wedges.
void check_wedge_ball_info(const VolumeInfo& info) {
  REQUIRE(info.labels.size() == 5);
  const std::vector<std::vector<uint16_t>> expected = {{1, 2, 3}, {0, 2, 3, 4}, {0, 1, 3, 4}, {0, 1, 2, 4}, {1, 2, 3}};
  for (uint16_t l = 0; l < 5; ++l) {
    CHECK(info.labels[l].label == l);
    CHECK(info.labels[l].neighbours == expected[l]);
    CHECK(info.labels[l].voxels > 64);
  }
}

}  // namespace

TEST_CASE("wedge ball: labels, neighbour sets and junction counts") {
  for (int64_t n : {32, 48}) {
    SynthOptions o;
    o.size = n;
    const SynthVolume s = make_synth_volume(o);
    check_wedge_ball_info(summarize(s.volume));
    CHECK(s.junctions.triple_curves.size() == 8);
    CHECK(s.junctions.quadruple_points.size() == 4);
  }
}

TEST_CASE("wedge ball: analytic quadruple points and triple curves lie where their materials meet") {
  SynthOptions o;
  o.size = 64;
  o.spacing = {1.0, 1.0, 1.5};  // anisotropic: junctions are in physical units
  const SynthVolume s = make_synth_volume(o);
  for (const auto& q : s.junctions.quadruple_points) {
    const auto near = labels_near(s.volume, q.position, 2.5);
    for (uint16_t m : q.materials) CHECK(near.count(m) == 1);
  }
  for (const auto& c : s.junctions.triple_curves) {
    REQUIRE(c.points.size() > 100);
    for (size_t p = 0; p < c.points.size(); p += 32) {
      const auto near = labels_near(s.volume, c.points[p], 2.0);
      for (uint16_t m : c.materials) CHECK(near.count(m) == 1);
    }
  }
}

TEST_CASE("other synthetic shapes: sphere, slabs, shells keep their thin layers") {
  SynthOptions o;
  o.size = 24;
  o.shape = SynthShape::sphere;
  CHECK(summarize(make_synth_volume(o).volume).labels.size() == 2);
  o.shape = SynthShape::slabs;
  const VolumeInfo slabs = summarize(make_synth_volume(o).volume);
  REQUIRE(slabs.labels.size() == 5);
  CHECK(slabs.labels[2].voxels == 2 * 24 * 24);  // label 3: two voxels thick
  CHECK(slabs.labels[3].voxels == 24 * 24);      // label 4: one voxel thick
  CHECK(slabs.labels[3].neighbours == std::vector<uint16_t>{3, 5});
  o.shape = SynthShape::shells;
  o.size = 40;
  const VolumeInfo shells = summarize(make_synth_volume(o).volume);
  REQUIRE(shells.labels.size() == 6);
  CHECK(shells.labels[3].neighbours == std::vector<uint16_t>{2, 4});  // the 1.5-voxel shell separates 2 from 4
  CHECK(shells.labels[5].neighbours == std::vector<uint16_t>{4});     // the one-voxel shell sits inside shell 4
  CHECK_THROWS(parse_synth_shape("cube"));
}

TEST_CASE("head phantom: the seed paper's dims at size 250, four tissues in anatomical order, neck at the bottom face") {
  SynthOptions o;
  o.shape = parse_synth_shape("head");
  o.size = 250;
  const SynthVolume big = make_synth_volume(o);
  CHECK(big.volume.dims == std::array<int64_t, 3>{199, 250, 249});
  o.size = 80;
  CHECK(make_synth_volume(o).volume.dims == std::array<int64_t, 3>{64, 80, 80});
  // The layers are a few voxels thick at full size only (CSF 2.5 voxels over the gyri).
  const SynthVolume& s = big;
  const VolumeInfo info = summarize(s.volume);
  REQUIRE(info.labels.size() == 5);
  CHECK(info.labels[0].neighbours == std::vector<uint16_t>{1});        // air touches only the scalp and neck
  CHECK(info.labels[1].neighbours == std::vector<uint16_t>{0, 2, 3});  // the CSF sheath leaves through the neck
  CHECK(info.labels[2].neighbours == std::vector<uint16_t>{1, 3});     // skull between scalp and CSF
  CHECK(info.labels[3].neighbours == std::vector<uint16_t>{1, 2, 4});
  CHECK(info.labels[4].neighbours == std::vector<uint16_t>{3});        // the brain floats in CSF
  // Neck, sheath and brainstem reach the bottom face; the top of the head stays inside the volume.
  std::set<uint16_t> bottom, top;
  for (int64_t j = 0; j < s.volume.dims[1]; ++j)
    for (int64_t i = 0; i < s.volume.dims[0]; ++i) {
      bottom.insert(s.volume.labels[s.volume.index(i, j, 0)]);
      top.insert(s.volume.labels[s.volume.index(i, j, s.volume.dims[2] - 1)]);
    }
  CHECK(bottom == std::set<uint16_t>{0, 1, 3, 4});
  CHECK(top == std::set<uint16_t>{0});
  // The brain is the largest tissue.
  CHECK(info.labels[4].voxels > info.labels[1].voxels);
  CHECK(info.labels[4].voxels > info.labels[2].voxels);
}

TEST_CASE("bundled wedge ball asset: 5 labels, right neighbours, same as the generator, junction JSON") {
  const std::string dir = std::string(CPMESH_SOURCE_DIR) + "/assets/";
  const LabelVolume v = read_label_volume(dir + "wedge_ball_48.nrrd");
  CHECK(v.dims == std::array<int64_t, 3>{48, 48, 48});
  check_wedge_ball_info(summarize(v));
  SynthOptions o;
  o.size = 48;
  CHECK(v.labels == make_synth_volume(o).volume.labels);
  const std::string text = format_volume_info(summarize(v));
  CHECK(text.find("labels   5") != std::string::npos);
  std::ifstream in(dir + "wedge_ball_48.junctions.json");
  const auto j = nlohmann::json::parse(in);
  CHECK(j["triple_curves"].size() == 8);
  CHECK(j["quadruple_points"].size() == 4);
}

TEST_CASE("volume info warns about tiny labels") {
  LabelVolume v;
  v.dims = {10, 10, 10};
  v.labels.assign(1000, 0);
  v.labels[555] = 7;
  const std::string text = format_volume_info(summarize(v));
  CHECK(text.find("warning: label 7 has only 1 voxels") != std::string::npos);
  CHECK(text.find("warning: label 0") == std::string::npos);
}
