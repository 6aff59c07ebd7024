#pragma once
// The closest point embedding (seed paper Sec. 4; docs/design.md): for every feature (an interface between two materials,
// a triple curve of three, a quadruple point of four) a narrow band of voxel cells ("coarse level") each owning a
// block of sub^3 fine points (spacing S = 1/sub voxel) that store the closest point on that feature. Built once, on
// the CPU, by Newton projection onto the zero sets of f_i - f_j (one constraint for interfaces, two for curves) with
// Catmull-Rom interpolation of the indicator fields; looked up by WENO4 interpolation with no iterative search
// (ref::cp_lookup and shaders/cp_lookup.comp).
//
// Interfaces are patches bounded by their triple curves: a fine point whose projection lands beyond a bounding curve
// (where a third material wins) stores the closest point on that curve instead, and a curve point beyond a quadruple
// point stores the quadruple point. So a particle tagged with a feature can never be pulled off that feature.
//
// Coarse cells are found through an open-addressing hash table keyed by (cell index, feature), so memory grows with
// the interface area and the number of features, never with volume x features.
#include <array>
#include <functional>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "host/host_array.h"
#include "fields/indicator_fields.h"
#include "fields/material_set.h"

namespace cpmesh::fields {

enum class FeatureKind : uint8_t { quadruple_point = 0, triple_curve = 1, interface = 2 };

struct Feature {
  FeatureKind kind = FeatureKind::interface;
  std::array<uint16_t, 4> materials = {0xffff, 0xffff, 0xffff, 0xffff};  // indices into IndicatorFields::labels, ascending
  uint32_t components = 1;  // separate pieces with this material set: curves (26-connected), points (located)
  int material_count() const { return 4 - int(kind == FeatureKind::interface) * 2 - int(kind == FeatureKind::triple_curve); }
  // The particle system's interaction rule and the mesh's wrong-face test compare these.
  MaterialSet material_set() const { return MaterialSet(std::span(materials.data(), size_t(material_count()))); }
};

constexpr size_t kMaxFeatures = 65535;

// Each feature's material set, in feature order (what the particle system's masks hold).
inline std::vector<MaterialSet> material_sets(const std::vector<Feature>& features) {
  std::vector<MaterialSet> out;
  for (const Feature& f : features) out.push_back(f.material_set());
  return out;
}

struct EmbeddingOptions {
  int sub = 0;              // fine points per voxel and axis (S = 1 / sub); 0: embedding_subcells() chooses
  double band = 0.75;       // voxels: lookups within this distance of a feature are complete (stencil reach added)
  int newton_iterations = 30;
  int closest_point_rounds = 3;  // Newton + tangent re-projection rounds towards the true foot point
  double curve_smoothing = 3.0;  // voxels: sigma of the local quadratic fit that smooths triple curves along
                                 // themselves (below; 0: off)
  bool junction_extrapolation = true;  // before that fit, T-junction curve points go to where their interfaces,
                                       // extended from 2.5-6 voxels away, meet (below; needs curve_smoothing)
  // Called with the whole embedding's block count and subcells as soon as they are known, before any fine point is
  // projected: in the curve smoothing's pass (which counts every feature's blocks, though it projects only the
  // curves') and again in the embedding's. A limit that cannot be met (the device's bindings:
  // GpuEmbedding::check_fits) throws there, seconds into the fields rather than after the whole embedding.
  std::function<void(size_t blocks, int sub)> check_blocks;
};

// What an EmbeddingOptions::check_blocks throws where the embedding will not fit: why, and at how many subcells.
struct EmbeddingTooLarge : std::runtime_error {
  EmbeddingTooLarge(const std::string& why, int sub) : std::runtime_error(why), sub(sub) {}
  int sub;
};

// The fine spacing when EmbeddingOptions::sub is 0, from the smallest particle spacing the sizing field may ask for
// (SizingOptions::h_min, in voxels) and the share of the label-boundary voxels that lie in thin parts
// (IndicatorFields::protected_voxels, parts under about two voxels thick; build_fields counts it as 1 where they were
// not measured at a radius of at least a voxel), and the band when already chosen; build_fields passes them. One
// fine point per voxel where that floor is at least a voxel and at most kMaxThinShareForOneSubcell of the boundary
// is thin, else two per voxel and axis. The lookup interpolates the stored closest points, and its error grows as S^3 times
// the squared curvature (measured against direct Newton projections, 20,000 lookups within the band: a sphere of
// radius 20 voxels, mean / max 0.0007 / 0.034 voxel at S = 1/2 and 0.0027 / 0.067 at S = 1; radius 6, 0.006 / 0.20
// and 0.027 / 0.22); where the particles are at least a voxel apart this stays a few percent of their spacing,
// while S = 1 has an eighth of the fine points to project (the 128^3 wedge ball's embedding 4.4 -> 1.5 s). Across a
// thin layer the wider stencil mixes the layer's two sides: the 64^3 shells (one-voxel layers, a quarter of the
// boundary thin) at --min-size 1 were left with 2,070 wrong faces at S = 1 against 611 at S = 1/2; the wedge ball's
// few thin voxels (where its wedges meet the axis: 0.4% of the boundary at 128^3, 1.3% at 48^3) change nothing.
constexpr double kMaxThinShareForOneSubcell = 0.02;
// band_voxels (> 0): an indicator band already chosen; one subcell only where it is deep enough for its stencil.
int embedding_subcells(const EmbeddingOptions& options, double size_floor_voxels = 0, double thin_share = 0,
                       double band_voxels = 0);
// The indicator band (voxels) the embedding needs at `sub`: its lookup band plus the WENO4 stencil's reach (see
// build_closest_point_embedding), at least IndicatorOptions::kDefaultBand, in whole voxels: 4 at sub 2, 5 at sub 1.
// (4.5 would do at sub 1, but the smoothing raises the clamped values near the band's edge, and the 128^3 wedge
// ball's embedding then had 608 k blocks instead of 543 k, its embedding and sizing 10-20% slower.)
double embedding_indicator_band(const EmbeddingOptions& options, int sub);

struct ClosestPointEmbedding {
  Grid grid;
  int sub = 2;
  std::vector<Feature> features;          // interfaces, then triple curves, then quadruple points
  struct QuadruplePoint {
    uint32_t feature;      // its quadruple-point feature (one material set may meet at several points)
    glm::dvec3 position;   // local coordinates
  };
  std::vector<QuadruplePoint> quadruple_points;

  // Coarse level: hash table of (cell index << 16 | feature) -> block; empty slots hold kEmpty.
  static constexpr uint64_t kEmpty = ~0ull;
  static constexpr uint32_t kMaxProbes = 32;  // construction guarantees every key is found within this many probes
  std::vector<uint64_t> keys;
  std::vector<uint32_t> blocks;
  // Fine level: sub^3 points per block, x fastest: closest point (local coordinates) in xyz, w free for the sizing field.
  HostArray<glm::vec4> fine;

  // What the fine level took: the points computed (all of `fine`; the curve smoothing's own embedding drops its
  // blocks where no point landed afterwards), those where every Newton projection failed (they keep where the last
  // run stopped: in thin layers, where a material set meets in the labels but not in the smooth fields), and the
  // Newton iterations of all their projections.
  struct Stats {
    uint64_t fine_points = 0, failed_points = 0, newton_steps = 0;
    double failed_share() const { return fine_points ? double(failed_points) / double(fine_points) : 0.0; }
  } stats;

  size_t block_count() const { return fine.size() / size_t(sub * sub * sub); }
  size_t memory_bytes() const {
    return keys.size() * sizeof(uint64_t) + blocks.size() * sizeof(uint32_t) + fine.size() * sizeof(glm::vec4);
  }
  // Block of (cell, feature), or -1.
  int64_t find_block(size_t cell, uint32_t feature) const;
  int feature_index(FeatureKind kind, std::array<uint16_t, 4> materials) const;
  // Whether a block's cell touches its feature: the cell centre lies within half a voxel diagonal (0.87 voxel) of
  // the closest point of the block's first fine point. One such block per surface spot: the blocks further along
  // the normals repeat the same closest points.
  bool touches_feature(size_t cell, size_t block) const {
    const glm::dvec3 cp(glm::vec3(fine[block * size_t(sub * sub * sub)]));
    return glm::length((cp - grid.local(glm::dvec3(grid.voxel(cell)))) / grid.spacing) <= 0.87;
  }
};

uint32_t embedding_hash(uint64_t key);  // shared with shaders/cp_lookup.comp (same arithmetic)

// The open-addressing table behind the embedding's coarse level (and the sizing field's cell index): slots of
// `keys` (kEmpty when free) and `values`, linear probing from embedding_hash(key). Built from distinct keys, value i
// for keys[i]; the capacity is a power of two at least twice the keys, doubled until every key sits within
// max_probes of its home slot (the GPU lookup gives up after that many).
void build_hash_table(const std::vector<uint64_t>& distinct_keys, uint32_t max_probes, std::vector<uint64_t>& keys,
                      std::vector<uint32_t>& values);
// values of `key`, or -1.
int64_t find_in_hash_table(const std::vector<uint64_t>& keys, const std::vector<uint32_t>& values, uint64_t key,
                           uint32_t max_probes);

ClosestPointEmbedding build_closest_point_embedding(const IndicatorFields& fields, const EmbeddingOptions& options = {});

// Triple curves smoothed along themselves, done on the fields before the embedding is built (fields/fields_stage.cpp).
// Where a curve crosses a staircase step of one of its interfaces, the fields put it up to 0.8 voxel off (128^3 wedge
// ball), and no isotropic smoothing of the fields moves it: the step is in the data. So:
//  - triple_curve_moves: the curves' points (an embedding of the curves alone; one point per quarter-voxel cell) each
//    get a move in two steps, fading to none within 2 sigma of the quadruple points (they end the curve and are
//    located on their own):
//    1. T-junction extrapolation (EmbeddingOptions::junction_extrapolation). Where one material's flat side meets
//       two others (a plane ending on a ball: the "stem" ends on the "through surface"), the fields bend the stem
//       within about two voxels of the curve towards its last staircase step, because the smoothing there averages
//       it with the distance fields' extension of that step into the third material: up to 0.7 voxel at the 128^3
//       wedge ball's rim, where the rim runs along a grid axis, the step has the same phase for several voxels, and
//       no fit along the curve can average it. Both surfaces are right a few voxels away. So in the plane across the
//       curve at the point, each interface is sampled 2.5-6 voxels out (marching along its zero set, up to where a
//       fourth material takes over); the two whose tangents at the point (from a parabola through it, so a plane
//       ending on a small ball is a T-junction too) are less than 40 degrees from opposite are the through surface,
//       fitted with one parabola across the gap, the third is the stem, fitted with a line; the point goes 0.6 of
//       the way to where they meet (the meeting point carries the interfaces' staircase ripple, so a partial move
//       errs least). Y-junctions (no such pair), interfaces shorter than the samples, and moves over a voxel are
//       left alone.
//    2. The move to a weighted local quadratic fit of the (moved) curve points within 3 sigma (quadratic, so a
//       curved curve is not shrunk). A fit whose points do not lie along one smooth curve (residual over a quarter
//       voxel: two curves close together, a tiny loop) or that would move a point more than half a voxel moves
//       nothing.
//  - warp_fields: every field takes, at voxel x, its value at x - d(x), where d is the mean move of the curve points
//    near x, in full within a voxel of a curve and fading to none 3.5 voxels away. So the curve moves and the
//    interfaces that meet there bend with it: moving the embedding's curve points alone left the surfaces' ends where
//    they were, and the meshes lost their manifold interfaces. Returns how many voxel values changed.
//  - smooth_triple_curves: both, with what they did.
// Measured on the wedge ball, the meshes' triple-curve edges (midpoints) to the analytic curves, mean / max in
// voxels, with the extrapolation against without it (both with the fit), when only flat T-junctions were
// extrapolated: 40^3 (seeds 1, 2) 0.16 / 0.51-0.52 vs 0.23 / 0.56; 48^3 (seeds 1-3) 0.12 / 0.29-0.34 vs 0.21-0.23 /
// 0.46-0.51; 64^3 (seeds 1, 2) 0.14 / 0.40-0.46 vs 0.20 / 0.42-0.44; 128^3 (seeds 1, 2) 0.12 / 0.37-0.38 vs
// 0.19-0.20 / 0.65-0.66. With the inner-ball curves extrapolated too and the sizing field's chord bound
// (sizing_field.h), whole edges (ends included) at most 0.43-0.46 voxel off at 48^3 (seeds 1-3; 0.53-0.54 before),
// 0.47 at 64^3, 0.42 at 128^3. What limits it: the planes' own staircase ripple a few voxels from the curve (+-0.3
// voxel at 64^3, with a period of about 13 voxels for a plane near the diagonal), and the quadruple points (at 40^3
// the south pole, where three wedge tips meet the background, 0.7 voxel off; curve edge midpoints 0.54 there).
struct CurveMove {
  glm::dvec3 position;        // a curve point, local coordinates
  glm::dvec3 move;            // where the smoothing moves it (0: not moved)
  bool extrapolated = false;  // the move includes a T-junction extrapolation
};
std::vector<CurveMove> triple_curve_moves(const IndicatorFields& fields, const EmbeddingOptions& options = {});
size_t warp_fields(IndicatorFields& fields, const std::vector<CurveMove>& moves);
struct CurveSmoothing {
  size_t curve_points = 0;    // representatives measured (one per quarter-voxel cell of a curve)
  size_t moved_points = 0;    // of those, moved
  size_t extrapolated_points = 0;  // of those, moved with a T-junction extrapolation
  double largest_move = 0;    // voxels
  size_t changed_values = 0;  // field values the warp changed, all materials
};
CurveSmoothing smooth_triple_curves(IndicatorFields& fields, const EmbeddingOptions& options = {});

// Closest point on a feature of the smooth (Catmull-Rom) fields, by Newton projection; what the embedding stores.
// `start` (optional) is where the first Newton solve begins, e.g. a nearby point's closest point. Returns false when
// the projection did not converge. give_up_stagnating: a Newton run whose residual stops shrinking fails at once
// rather than after newton_iterations (where the feature does not exist it costs about 8 steps instead of 30).
bool project_to_feature(const IndicatorFields& fields, const Feature& feature, const glm::dvec3& local, glm::dvec3& out,
                        int newton_iterations = 30, int rounds = 3, const glm::dvec3* start = nullptr,
                        bool give_up_stagnating = false);

// How far `local` lies from a feature of the smooth fields, to first order: over the feature's constraints
// f_{m0} - f_{ma} = 0 the largest |f_{m0} - f_{ma}| / |grad(f_{m0} - f_{ma})| (physical units), and by how much
// another material's field exceeds the feature's lowest (a material interface is where its two fields are equal and
// the largest); infinity where a constraint's gradient vanishes. A point the embedding put on the feature gives about
// 0.
double feature_distance(const IndicatorFields& fields, const Feature& feature, const glm::dvec3& local);

}  // namespace cpmesh::fields
