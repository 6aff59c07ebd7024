#include "mesh/report_json.h"

namespace cpmesh::mesh {

nlohmann::json volume_runs_json(const MeshReport& rep) {
  nlohmann::json runs = nlohmann::json::array();
  for (const auto& run : rep.volume_runs)
    runs.push_back({{"label", run.material < rep.materials.size() ? nlohmann::json(rep.materials[run.material].label)
                                                                  : nlohmann::json("all")},
                    {"piece", run.piece},
                    {"pieces", run.pieces},
                    {"tetgen_s", run.tetgen},
                    {"slivers_s", run.slivers},
                    {"tets", run.tets},
                    {"added_points", run.added_points},
                    {"interior_points", run.interior_points}});
  return runs;
}

}  // namespace cpmesh::mesh
