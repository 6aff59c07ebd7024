#include "fields/fields_stage.h"

#include <chrono>
#include <functional>

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

namespace cpmesh::fields {

namespace {

double size_floor_voxels(const FieldsOptions& options, double voxel) {
  return options.sizing.h_min > 0 ? options.sizing.h_min / voxel : 0.0;  // 0: a quarter voxel
}

// Voxels with a 6-neighbour of another label.
size_t boundary_voxels(const Grid& grid, const uint16_t* labels) {
  return tbb::parallel_reduce(
      tbb::blocked_range<int>(0, grid.dims.z), size_t(0),
      [&](const tbb::blocked_range<int>& r, size_t count) {
        const glm::ivec3 d = grid.dims;
        for (int k = r.begin(); k < r.end(); ++k)
          for (int j = 0; j < d.y; ++j)
            for (int i = 0; i < d.x; ++i) {
              const uint16_t l = labels[grid.index(i, j, k)];
              bool differs = false;
              for (int a = 0; a < 3 && !differs; ++a)
                for (int side : {-1, 1}) {
                  glm::ivec3 q(i, j, k);
                  q[a] += side;
                  differs |= q[a] >= 0 && q[a] < d[a] && labels[grid.index(q.x, q.y, q.z)] != l;
                }
              count += differs;
            }
        return count;
      },
      std::plus<>());
}

}  // namespace

FieldsOptions resolve_fields_options(FieldsOptions options, double voxel) {
  // The band is needed before the fields: for the subcells the floor allows (thin parts can only make them more).
  if (options.indicator.band <= 0)
    options.indicator.band = embedding_indicator_band(
        options.embedding, embedding_subcells(options.embedding, size_floor_voxels(options, voxel), 0.0, 0.0));
  return options;
}

FieldsResult build_fields(const Grid& grid, const uint16_t* labels, const FieldsOptions& given) {
  FieldsOptions options = resolve_fields_options(given, grid.min_spacing());
  using clock = std::chrono::steady_clock;
  auto seconds_since = [](clock::time_point t) { return std::chrono::duration<double>(clock::now() - t).count(); };
  FieldsResult r;
  auto t = clock::now();
  r.fields = build_indicator_fields(grid, labels, options.indicator);
  r.report.indicator_seconds = seconds_since(t);
  r.report.indicator_bytes = r.fields.memory_bytes();
  // Thin parts as measured at a radius of at least a voxel (parts under about two voxels thick); where the tightening
  // measured them at a smaller radius, or not at all, they count as everywhere (two subcells).
  const size_t boundary = r.report.boundary_voxels = boundary_voxels(grid, labels);
  r.report.thin_share = r.fields.thin_radius < 1.0 ? 1.0
                        : boundary > 0            ? double(r.fields.protected_voxels) / double(boundary)
                                                  : 0.0;
  options.embedding.sub = embedding_subcells(options.embedding, size_floor_voxels(options, grid.min_spacing()),
                                             r.report.thin_share, options.indicator.band);
  t = clock::now();
  r.report.curve_smoothing = smooth_triple_curves(r.fields, options.embedding);
  r.embedding = build_closest_point_embedding(r.fields, options.embedding);
  r.report.embedding_seconds = seconds_since(t);
  t = clock::now();
  r.report.sizing = compute_sizing_field(r.fields, r.embedding, options.sizing);
  r.report.sizing_seconds = seconds_since(t);
  r.report.embedding_bytes = r.embedding.memory_bytes();
  for (const auto& f : r.embedding.features) {
    r.report.interfaces += f.kind == FeatureKind::interface;
    if (f.kind == FeatureKind::triple_curve) r.report.triple_curves += f.components;
  }
  r.report.quadruple_points = r.embedding.quadruple_points.size();
  return r;
}

}  // namespace cpmesh::fields
