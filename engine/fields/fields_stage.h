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

FieldsResult build_fields(const Grid& grid, const uint16_t* labels, const FieldsOptions& options = {});

}  // namespace cpmesh::fields
