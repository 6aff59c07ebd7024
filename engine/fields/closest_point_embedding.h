#pragma once
// The closest point embedding (seed paper Sec. 4; DESIGN.md): for every feature (an interface between two materials,
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
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "fields/indicator_fields.h"

namespace cpmesh::fields {

enum class FeatureKind : uint8_t { quadruple_point = 0, triple_curve = 1, interface = 2 };

struct Feature {
  FeatureKind kind = FeatureKind::interface;
  std::array<uint16_t, 4> materials = {0xffff, 0xffff, 0xffff, 0xffff};  // indices into IndicatorFields::labels, ascending
  uint32_t components = 1;  // separate pieces with this material set: curves (26-connected), points (located)
  int material_count() const { return 4 - int(kind == FeatureKind::interface) * 2 - int(kind == FeatureKind::triple_curve); }
  // Bit m set for each material m of the feature: the particle system's interaction rule and the mesh repair compare
  // these. Throws for a material index of 64 or more (the particle system supports at most 64 materials).
  uint64_t material_mask() const {
    uint64_t m = 0;
    for (int a = 0; a < material_count(); ++a) {
      if (materials[size_t(a)] >= 64) throw std::runtime_error("the particle system supports at most 64 materials");
      m |= uint64_t(1) << materials[size_t(a)];
    }
    return m;
  }
};

struct EmbeddingOptions {
  int sub = 2;              // fine points per voxel and axis (S = 1 / sub)
  double band = 0.75;       // voxels: lookups within this distance of a feature are complete (stencil reach added)
  int newton_iterations = 30;
  int closest_point_rounds = 3;  // Newton + tangent re-projection rounds towards the true foot point
};

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
  std::vector<glm::vec4> fine;

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

ClosestPointEmbedding build_closest_point_embedding(const IndicatorFields& fields, const EmbeddingOptions& options = {});

// Closest point on a feature of the smooth (Catmull-Rom) fields, by Newton projection; what the embedding stores.
// `start` (optional) is where the first Newton solve begins, e.g. a nearby point's closest point. Returns false when
// the projection did not converge.
bool project_to_feature(const IndicatorFields& fields, const Feature& feature, const glm::dvec3& local, glm::dvec3& out,
                        int newton_iterations = 30, int rounds = 3, const glm::dvec3* start = nullptr);

}  // namespace cpmesh::fields
