#pragma once
// The fields stage of the pipeline in one call: indicator fields, closest point embedding, sizing field, with the
// time and memory of each step (docs/design.md, "Pipeline and data flow").
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
  size_t boundary_voxels = 0;  // voxels with a 6-neighbour of another label (interface voxels)
  double thin_share = 0;       // of those, the share in thin parts (IndicatorFields::protected_voxels; 1 where thin
                               // parts were not measured at a radius of at least a voxel)
  SizingStats sizing;
  CurveSmoothing curve_smoothing;  // done between the indicator fields and the embedding; its time is the embedding's
};

struct FieldsResult {
  IndicatorFields fields;
  ClosestPointEmbedding embedding;
  FieldsReport report;
};

// The options with the indicator band chosen when 0, for a grid whose smallest spacing is `voxel` (physical): what
// the embedding needs at the subcells the sizing floor h_min allows (embedding_indicator_band, embedding_subcells).
// build_fields applies it, then chooses the subcells themselves when 0 once the indicator fields have measured the
// thin parts; a closed volume's padding needs the band before (face_padding).
FieldsOptions resolve_fields_options(FieldsOptions options, double voxel);

FieldsResult build_fields(const Grid& grid, const uint16_t* labels, const FieldsOptions& options = {});

}  // namespace cpmesh::fields
