#pragma once
// The synthetic test volumes of docs/design.md with their known answers, in physical units (origin 0, voxel (i,j,k) at
// (i,j,k) * spacing). Labels come from testing each voxel centre against the analytic shapes.
//   sphere:     label 1 inside a ball (default radius 0.35 * size voxels), 0 outside.
//   wedge-ball: background 0; a ball (radius 50 voxels at size 128, scaled with size) cut into wedges 1, 2, 3 by three
//               half-planes through its vertical axis at 120 degrees; an off-centre inner ball 4 (radius 18/50 of the
//               outer) that contains a piece of the axis and so crosses every wedge plane. 9 interfaces, 8 triple
//               curves, 4 quadruple points.
//   slabs:      layers along z: 1, 2, then 3 (two voxels thick), 4 (one voxel thick), 5.
//   shells:     concentric shells around a core 1: 2, 3 (1.5 voxels thick), 4, 5 (one voxel thick), background 0.
//   head:       a head phantom the size of the seed paper's head (199 x 250 x 249 voxels at size 250; size is the
//               y extent and the other two scale with it): air 0, scalp and neck 1, skull 2 (5-8 voxels thick),
//               CSF 3, a folded brain 4 (gyri 9 voxels deep). A brainstem in a CSF sheath leaves through a hole
//               in the skull base, so skull, CSF and neck meet along a triple curve; neck and brainstem end at
//               the volume's bottom face. Four tissues and air; no analytic junctions are written.
// Lengths given in voxels are multiplied by the smallest spacing, so shapes stay round with anisotropic spacing.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "io/volume.h"

namespace cpmesh::io {

// The corpus kinds (parcellation, thin, islands, organs) are described in synth_corpus.h.
enum class SynthShape { sphere, wedge_ball, slabs, shells, head, parcellation, thin, islands, organs };

struct SynthOptions {
  SynthShape shape = SynthShape::wedge_ball;
  int64_t size = 64;                    // voxels along each axis (head: along y)
  std::array<double, 3> spacing{1, 1, 1};
  double radius = 0;                    // outer radius in voxels (sphere, wedge ball, shells); 0: the default
  int labels = 0;                       // parcels of the parcellation (2..1000); 0: the default (80)
  double noise = 0;                     // corpus kinds: share of boundary voxels flipped to a neighbour's label
  uint64_t seed = 1;                    // corpus kinds: the random layout
};

struct TripleCurve {
  std::array<uint16_t, 3> materials;            // ascending
  std::vector<std::array<double, 3>> points;    // a finely sampled polyline, physical units
};

struct QuadruplePoint {
  std::array<uint16_t, 4> materials;  // ascending
  std::array<double, 3> position;
};

struct Junctions {
  std::vector<TripleCurve> triple_curves;
  std::vector<QuadruplePoint> quadruple_points;
};

struct SynthVolume {
  LabelVolume volume;
  std::array<double, 3> centre{0, 0, 0};  // of the sphere, wedge ball or shells (physical)
  Junctions junctions;  // empty except for the wedge ball
  std::string description;  // the analytic parameters, for the JSON file
};

// Distance from p to the analytic triple curve(s) of three (ascending) labels, physical units; infinity when the
// junctions have no such curve.
double distance_to_triple_curve(const Junctions& j, const std::array<uint16_t, 3>& materials, const std::array<double, 3>& p);

// "sphere", "wedge-ball", "slabs", "shells", "head", "parcellation", "thin", "islands", "organs"
SynthShape parse_synth_shape(const std::string& name);
const char* synth_shape_name(SynthShape s);
// Throws (naming the field) for options make_synth_volume refuses: size outside 4..2048, a spacing that is not
// positive, a negative radius, labels outside 2..1000 (0: default), noise outside 0..0.5.
void check_synth_options(const SynthOptions& o);
SynthVolume make_synth_volume(const SynthOptions& o);
// JSON: {"shape", "parameters", "quadruple_points": [{"materials", "position"}], "triple_curves": [{"materials",
// "points"}]}, written atomically.
void write_junctions_json(const std::string& path, const SynthVolume& s);

}  // namespace cpmesh::io
