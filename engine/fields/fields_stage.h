#pragma once
// The fields stage of the pipeline in one call: indicator fields, closest point embedding, sizing field, with the
// time and memory of each step (DESIGN.md: GenerateDistanceVolumes, GenerateSizingFields, BuildClosestPointEmbedding).
#include "fields/sizing_field.h"

namespace cpmesh::fields {

struct FieldsOptions {
  IndicatorOptions indicator;
  EmbeddingOptions embedding;
  SizingOptions sizing;
};

struct FieldsReport {
  double indicator_seconds = 0, embedding_seconds = 0, sizing_seconds = 0;
  size_t indicator_bytes = 0, embedding_bytes = 0;
  size_t interfaces = 0, triple_curves = 0, quadruple_points = 0;
  SizingStats sizing;
  CurveSmoothing curve_smoothing;  // done between the indicator fields and the embedding; its time is the embedding's
};

struct FieldsResult {
  IndicatorFields fields;
  ClosestPointEmbedding embedding;
  FieldsReport report;
};

// The options with their automatic choices made, for a grid whose smallest spacing is `voxel` (physical): the
// embedding's subcells when 0 (embedding_subcells, from the sizing floor h_min) and the indicator band when 0 (what
// that embedding needs, embedding_indicator_band). build_fields applies it; a closed volume's padding needs the band
// before (face_padding).
FieldsOptions resolve_fields_options(FieldsOptions options, double voxel);

FieldsResult build_fields(const Grid& grid, const uint16_t* labels, const FieldsOptions& options = {});

}  // namespace cpmesh::fields
