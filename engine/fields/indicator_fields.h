#pragma once
// Per-material indicator fields (seed paper Sec. 3.1, 3.3; docs/design.md, "Multi-material rules").
//
// For each material m: the signed distance to the boundary of its voxel mask (exact EDT; positive inside), smoothed
// by a Gaussian under the constraint that every voxel keeps its sign (Whitaker's constrained antialiasing): the
// smoothing removes the staircase but can never move an interface across a voxel centre, so argmax_m f_m at every
// voxel centre is that voxel's label, and layers one voxel thick or single-voxel components survive.
// A Gaussian of variance s^2 also shrinks every curved surface by s^2 times its mean curvature (a ball of radius 18.75
// voxels came out 0.107 voxel small, its mesh 0.35 voxel off at worst); subtracting (s^2 / 2) times the Laplacian of
// the smoothed field, itself smoothed so the staircase is not sharpened back, undoes that (curvature_correction:
// 0.21 voxel at worst).
// A sign alone lets an island of a few voxels shrink to almost nothing (its fields near 0 at its centres after the
// first pass), and it then meshes as a flat double layer of slivers: at the voxels of thin islands every field keeps
// island_margin from 0 (docs/design.md, "Small islands").
// Then the paper's "tightening" (Williams & Rossignac): a curvature-limited level-set flow that moves the surface only
// where a principal curvature radius is below r, and never more than r from the antialiased surface (the r-tube).
// Tightening may move a surface across voxel centres; three things keep it honest:
//  - parts thinner than about 2r (no voxel of the material is r deep within 2r of them: sheets, vessels, small
//    components) are protected and kept as they are; their voxel count is reported (IndicatorFields::protected_voxels);
//  - the flow fades out near junctions (where the smoothing turns into twicing), so triple curves and quadruple
//    points stay put;
//  - the voxel centres that did change material are counted per material (tightened_voxels).
// Even so, smoothing and interpolating a distance field round a material's wedge-shaped edge: at a triple curve where
// a material's flat side meets two 90-degree edges (a ball cut by a plane), the flat material grows into the wedges
// by about 0.25 voxel. A Gaussian lowers a signed distance field at the apex of a wedge of angle a by sigma * sqrt(pi/2)
// * k(a), k(a) = (a/2 - pi/2 - cos(a/2)) / pi, which is 0 for a flat side, negative for a convex edge and positive for a
// concave one. So each material's field is raised by o_m = -junction_correction * k(a) near junctions (a = 2 pi times
// the share of its voxels in a 3-voxel ball around the mean nearby 3-label junction corner; fading out over
// junction_fade; every voxel keeps its sign). The offsets bend the interfaces back near the curves; they are also
// kept apart (junction_offsets) so the sizing field can measure thickness without them.
// Default 0.4. Measured on the wedge ball against 0 (both with the curvature correction above): the embedding's curve
// points lie 0.24-0.26 voxel off the analytic curves on average instead of 0.29-0.32 (max 0.83 -> 0.72 at 40^3,
// 0.67 -> 0.62 at 48^3, 0.84 -> 0.82 at 128^3); the meshes' triple-curve edges 0.21-0.25 instead of 0.29-0.31 (max
// 0.66 -> 0.53 at 40^3, 0.56 -> 0.48 at 48^3, 0.47 -> 0.47 at 64^3, 0.63 -> 0.66 at 128^3), for 0-11% more
// particles. At 0.6 the sizing field reads the bends as curvature: more particles, worse triangles, no better
// worst edge.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "fields/brick_field.h"

namespace cpmesh::fields {

struct IndicatorOptions {
  static constexpr double kDefaultBand = 4.0;  // voxels: the band when `band` is 0 and nothing asks for more
  double smoothing_sigma = 1.0;  // Gaussian sigma, in voxels of the smallest spacing
  int smoothing_iterations = 2;  // smooth + constrain rounds
  double band = 0;               // narrow-band half-width, in voxels of the smallest spacing (0: 4, or what
                                 // build_fields' closest point embedding needs: embedding_indicator_band)
  double junction_fade = 3.0;    // voxels: this close to where three or more labels meet, the smoothing turns into
                                 // twicing (below) to keep triple curves in place (0: plain smoothing everywhere)
  double junction_sigma = 0.7;   // voxels: sigma of the twiced Gaussian used at junctions (0: plain smoothing there)
  bool curvature_correction = true;  // undo the smoothing's shrinkage of curved surfaces (indicator_fields.cpp)
  double curvature_sigma = 1.5;      // voxels: Gaussian applied to the Laplacian that the correction subtracts
  double junction_correction = 0.4;  // voxels: amplitude of the wedge-angle correction at junctions (below; 0: off)
  // voxels: at the voxels of thin islands (protected from tightening, below, in a face-connected component of at
  // most island_voxels with one label around it), every field stays at least this far from 0 with the voxel's sign (0: the sign only, as
  // everywhere else). Not on sheets and tubes: there it pins the surface to the staircase.
  double island_margin = 0.4;  // islands-48 holds every check with it (docs/design.md); 0: the sign only
  size_t island_voxels = 64;
  double tighten_radius = 1.0;   // r, in voxels of the smallest spacing: smallest curvature radius kept (0: off)
  int tighten_iterations = 0;    // flow steps (0: automatic, enough to move r)
};

struct IndicatorFields {
  Grid grid;
  double band = 0;                   // physical half-width of the stored band
  std::vector<uint16_t> labels;      // label value of each material, ascending
  std::vector<BrickField> fields;    // f_m, same order as labels
  std::vector<BrickField> junction_offsets;  // o_m, already added to fields (0 away from junctions); empty when off
  std::vector<uint64_t> voxel_counts;
  std::vector<uint64_t> tightened_voxels;  // per material: voxel centres the tightening moved out of or into it
  uint64_t protected_voxels = 0;           // voxels in parts thinner than ~2r, left untightened
  double thin_radius = 0;                  // voxels: the r of protected_voxels (0: thin parts not measured)

  // Per brick of the fields (BrickField::brick_dims, x fastest): the materials whose fields are not -band all through
  // that brick and its 26 neighbours, ascending, at near_list[near_begin[b] .. near_begin[b + 1]). Any other
  // material's field is -band (its floor) everywhere within two voxels of the brick, where every cubic or linear
  // sample of a point in the brick reads, so no other material can win an argmax there or rise above a feature's
  // fields: what is near a point is a few materials however many the volume has.
  std::vector<uint32_t> near_begin;
  std::vector<uint16_t> near_list;

  size_t material_count() const { return labels.size(); }
  // The materials near a continuous voxel-index position (near_list; clamped to the grid).
  std::span<const uint16_t> materials_near(const glm::dvec3& ijk) const;
  // Index (into labels) of argmax_m f_m at a continuous voxel-index position (trilinear samples).
  int material_at(const glm::dvec3& ijk) const;
  size_t memory_bytes() const;
};

// Fills near_begin and near_list from the fields (build_indicator_fields does, last).
void index_materials_near(IndicatorFields& fields);

// labels: grid.voxel_count() values, x fastest. Every label value present becomes a material (the background too).
IndicatorFields build_indicator_fields(const Grid& grid, const uint16_t* labels, const IndicatorOptions& options = {});

// The antialiasing's separable Gaussian along one axis (0 x, 1 y, 2 z) of an n.x x n.y x n.z array f (x fastest),
// in place: sample q becomes float(sum over r of w_r f[clamp(q + r)]), r from -ceil(3 sigma) to ceil(3 sigma), the
// weights exp(-r^2 / (2 sigma^2)) normalised, summed in double in that order; samples beyond the ends repeat the
// edge, so a window that holds one value gives that value back. sigma in samples; <= 0: nothing.
void gaussian_pass(std::span<float> f, const glm::ivec3& n, int axis, double sigma);

}  // namespace cpmesh::fields
