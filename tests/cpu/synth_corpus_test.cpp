// The realistic corpus (io/synth_corpus.h): each kind has what real label maps have and what the tests on it rely
// on: many labels with non-contiguous ids, one-voxel sheets and tubes, islands of one voxel, a label of two voxels,
// enclosed pockets, labels cut by the volume's faces, isolated flipped voxels, and the same volume for the same seed.
#include <doctest/doctest.h>

#include <algorithm>
#include <map>
#include <set>

#include "io/synth_corpus.h"
#include "io/volume_info.h"
#include "label_maps.h"

using namespace cpmesh::io;
using cpmesh::test::components;

namespace {

const LabelInfo& info_of(const VolumeInfo& info, uint16_t label) {
  for (const auto& l : info.labels)
    if (l.label == label) return l;
  FAIL("no label " << label);
  return info.labels.front();
}

SynthVolume corpus_volume(const std::string& name) { return make_synth_volume(corpus_entry(name).options); }

}  // namespace

TEST_CASE("corpus: every entry is known by name, and a volume is the same for the same seed") {
  CHECK_THROWS_WITH(corpus_entry("nope"), doctest::Contains("field 'corpus'"));
  for (const auto& e : corpus())
    if (!e.large) CHECK(corpus_entry(e.name).options.shape == e.options.shape);
  const auto a = corpus_volume("parcellation-48"), b = corpus_volume("parcellation-48");
  CHECK(a.volume.labels == b.volume.labels);
  SynthOptions other = corpus_entry("parcellation-48").options;
  other.seed = 2;
  CHECK(make_synth_volume(other).volume.labels != a.volume.labels);
}

TEST_CASE("corpus: a parcellation has its labels, non-contiguous ids, small and large parcels, and labels on the faces") {
  for (const char* name : {"parcellation-48", "parcellation-300"}) {
    const auto s = corpus_volume(name);
    const VolumeInfo info = summarize(s.volume);
    const int want = corpus_entry(name).options.labels;
    CHECK(int(info.labels.size()) == want + 1);  // the parcels and the background
    const uint16_t largest_id = info.labels.back().label;
    CHECK(largest_id > 1000);
    CHECK(int(largest_id) > 2 * want);  // ids spread over 1..max(1100, 4 labels), not 1..labels
    int64_t smallest = INT64_MAX, largest = 0;
    size_t most_neighbours = 0;
    for (const auto& l : info.labels) {
      if (l.label == 0) continue;
      smallest = std::min(smallest, l.voxels);
      largest = std::max(largest, l.voxels);
      most_neighbours = std::max(most_neighbours, l.neighbours.size());
    }
    CHECK(smallest <= 60);     // the tiny parcels
    CHECK(largest >= 20 * smallest);
    CHECK(most_neighbours >= 8);  // many triple curves and quadruple points
    // Cropped by the y faces and cut by the bottom face (the stem).
    std::set<uint16_t> on_y0, on_z0;
    for (int64_t k = 0; k < s.volume.dims[2]; ++k)
      for (int64_t i = 0; i < s.volume.dims[0]; ++i) on_y0.insert(s.volume.labels[s.volume.index(i, 0, k)]);
    for (int64_t j = 0; j < s.volume.dims[1]; ++j)
      for (int64_t i = 0; i < s.volume.dims[0]; ++i) on_z0.insert(s.volume.labels[s.volume.index(i, j, 0)]);
    CHECK(on_y0.size() >= 3);
    CHECK(on_z0.size() >= 2);
  }
}

TEST_CASE("corpus: thin structures are one and two voxels thick and cross other labels") {
  const auto s = corpus_volume("thin-48");
  const LabelVolume& v = s.volume;
  const VolumeInfo info = summarize(v);
  // The falx (40) is one voxel thick along x: no voxel of it has a 40 on both x sides, and most have neither.
  int64_t sheet = 0, with_x_neighbour = 0;
  for (int64_t k = 0; k < v.dims[2]; ++k)
    for (int64_t j = 0; j < v.dims[1]; ++j)
      for (int64_t i = 1; i + 1 < v.dims[0]; ++i) {
        if (v.labels[v.index(i, j, k)] != 40) continue;
        ++sheet;
        with_x_neighbour += v.labels[v.index(i - 1, j, k)] == 40 || v.labels[v.index(i + 1, j, k)] == 40;
      }
  CHECK(sheet > 300);
  CHECK(with_x_neighbour < sheet / 2);
  // The CSF sheet lies between brain and skull and touches the falx and both tubes.
  CHECK(info_of(info, 30).neighbours == std::vector<uint16_t>{10, 20, 40, 50, 60});
  // The two-voxel tube crosses every layer and reaches the background and the volume's faces.
  CHECK(info_of(info, 60).neighbours.size() >= 6);
  CHECK(info_of(info, 60).min_voxel[0] == 0);
  // The one-voxel tube pierces the falx; the vessel wall encloses its lumen.
  CHECK(info_of(info, 50).voxels < 60);
  CHECK(std::count(info_of(info, 50).neighbours.begin(), info_of(info, 50).neighbours.end(), 40) == 1);
  CHECK(info_of(info, 80).neighbours == std::vector<uint16_t>{10, 60, 70});  // the lumen's ends touch the brain
}

TEST_CASE("corpus: islands of 1 to 64 voxels, pockets of background, and a label of two voxels") {
  const auto s = corpus_volume("islands-48");
  const auto three = components(s.volume, 3);
  CHECK(three == std::vector<int64_t>{1, 2, 4, 8, 16, 27, 64});
  const auto two = components(s.volume, 2);
  CHECK(std::count(two.begin(), two.end(), 1) == 1);  // an island of one voxel of 2 inside 1
  const auto ones = components(s.volume, 1);
  CHECK(ones.front() == 1);  // an island of 1 in the background
  const auto background = components(s.volume, 0);
  CHECK(background.size() >= 4);  // the outside and the enclosed pockets
  CHECK(components(s.volume, 5) == std::vector<int64_t>{2});
  const VolumeInfo info = summarize(s.volume);
  CHECK(info_of(info, 5).neighbours == std::vector<uint16_t>{0, 1});
}

TEST_CASE("corpus: organs with anisotropic spacing, a tube through the faces, a label of two voxels, isolated flips") {
  const auto s = corpus_volume("organs-64");
  const VolumeInfo info = summarize(s.volume);
  CHECK(s.volume.dims == std::array<int64_t, 3>{64, 52, 24});
  CHECK(s.volume.spacing == std::array<double, 3>{0.62, 0.62, 1.33});
  CHECK(info_of(info, 9).voxels == 2);
  CHECK(info_of(info, 5).min_voxel[2] == 0);
  CHECK(info_of(info, 5).max_voxel[2] == s.volume.dims[2] - 1);
  CHECK(info_of(info, 1).min_voxel[2] == 0);
  // Noise: flipped voxels are mostly isolated (no flipped neighbour): compare with the noiseless volume.
  SynthOptions clean = corpus_entry("organs-64").options;
  clean.noise = 0;
  const auto c = make_synth_volume(clean);
  std::vector<size_t> flipped;
  for (size_t i = 0; i < c.volume.labels.size(); ++i)
    if (c.volume.labels[i] != s.volume.labels[i]) flipped.push_back(i);
  CHECK(flipped.size() > 20);
  CHECK(flipped.size() < c.volume.labels.size() / 50);
}

TEST_CASE("corpus: bad options name their field") {
  SynthOptions o;
  o.shape = SynthShape::parcellation;
  o.labels = 1;
  CHECK_THROWS_WITH(make_synth_volume(o), doctest::Contains("field 'labels'"));
  o.labels = 10;
  o.noise = 0.9;
  CHECK_THROWS_WITH(make_synth_volume(o), doctest::Contains("field 'noise'"));
}
