#pragma once
// The realistic corpus: generated label maps that look like real segmentations (staircase boundaries, one- and
// two-voxel sheets and tubes, islands of a few voxels, many labels with non-contiguous ids, isolated flipped voxels,
// anisotropic spacing, labels cut by the volume's faces), for the tests and benchmarks that must hold on data like
// users have, not only on smooth analytic shapes (docs/design.md, "The realistic corpus").
//
// Every kind is deterministic in (size, spacing, labels, noise, seed). Shapes are laid out in physical units with
// lengths in voxels multiplied by the smallest spacing (as in synth_volumes.h), and labelled at voxel centres.
//   parcellation: a brain-like mask (a bumpy ellipsoid cropped by the y faces, with a stem through the bottom face)
//                 packed with `labels` parcels (default 80): a Voronoi partition of random seeds with per-seed speeds
//                 and densities (small parcels near the rim, large ones deep), warped by 3-D value noise so the
//                 boundaries are irregular staircases; a few parcels of 20-60 voxels; ids drawn without repetition
//                 from 1..max(1100, 4 * labels), so they are not contiguous and some exceed 1000.
//   thin:         a head-like layering (brain 10, CSF sheet 30 one voxel thick on one side and two on the other,
//                 skull 20, background 0) with a one-voxel sheet 40 inside the brain ending on the CSF (a falx),
//                 a one-voxel tube 50 through the brain that pierces the falx, a two-voxel tube 60 crossing brain,
//                 CSF, skull and background, and a vessel: wall 70 one voxel thick around a lumen 80.
//   islands:      two large touching blobs 1 and 2 in background 0 with islands of 1 to 64 voxels (label 3 inside
//                 1, label 2 inside 1, label 1 in the background), enclosed pockets of background inside 2, and a
//                 label 5 of exactly two voxels beside the large label 1.
//   organs:       a CT-like abdomen (x by 0.8 x by 0.38 x voxels for size x): a body 1 through the top and bottom
//                 faces, liver 6, kidneys 2 and 3, spleen 4, an aorta 5 (a tube about 3 voxels across through both
//                 faces), a spine 7 and a label 9 of two voxels beside the liver.
// `noise` (0..0.5): the share of label-boundary voxels that take a 6-neighbour's label, chosen by a hash so the
// flips are isolated voxels.
#include <string>
#include <vector>

#include "io/synth_volumes.h"

namespace cpmesh::io {

bool is_corpus_shape(SynthShape s);
// Labels every voxel of `v` (dims, spacing and origin set) for a corpus kind; the description's parameters into
// `params` (JSON text of an object).
void make_corpus_volume(const SynthOptions& o, LabelVolume& v, std::string& params);

// The named corpus: what the tests and benchmarks run. "small" entries are 48^3-class volumes that mesh in seconds
// (CI); "large" ones are the benchmark sizes (up to about 25 M voxels).
struct CorpusEntry {
  std::string name;
  SynthOptions options;
  bool large = false;
};
const std::vector<CorpusEntry>& corpus();
// The entry named `name`; throws naming the field and the known names.
const CorpusEntry& corpus_entry(const std::string& name);

}  // namespace cpmesh::io
