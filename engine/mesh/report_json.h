#pragma once
// Parts of a MeshReport as JSON, shared by `cpmesh mesh` (report.json) and the pipeline benchmark (its JSON line).
#include <nlohmann/json.hpp>

#include "mesh/pipeline.h"

namespace cpmesh::mesh {

// One object per volume-mesh run (volume_mesh.h): label (the material's, or "all" for the one run over every
// material), piece, pieces, tetgen_s, slivers_s, tets, added_points, interior_points.
nlohmann::json volume_runs_json(const MeshReport& rep);

}  // namespace cpmesh::mesh
