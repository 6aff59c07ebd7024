#include "fields/fields_stage.h"

#include <chrono>

namespace cpmesh::fields {

FieldsOptions resolve_fields_options(FieldsOptions options, double voxel) {
  const double floor_voxels = options.sizing.h_min > 0 ? options.sizing.h_min / voxel : 0.0;  // 0: a quarter voxel
  options.embedding.sub = embedding_subcells(options.embedding, floor_voxels);
  if (options.indicator.band <= 0) options.indicator.band = embedding_indicator_band(options.embedding, options.embedding.sub);
  return options;
}

FieldsResult build_fields(const Grid& grid, const uint16_t* labels, const FieldsOptions& given) {
  const FieldsOptions options = resolve_fields_options(given, grid.min_spacing());
  using clock = std::chrono::steady_clock;
  auto seconds_since = [](clock::time_point t) { return std::chrono::duration<double>(clock::now() - t).count(); };
  FieldsResult r;
  auto t = clock::now();
  r.fields = build_indicator_fields(grid, labels, options.indicator);
  r.report.indicator_seconds = seconds_since(t);
  r.report.indicator_bytes = r.fields.memory_bytes();
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
