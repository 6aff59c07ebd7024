#pragma once
// The whole pipeline in one call (issue 8): a labeled volume and options in; interface triangle meshes, a tetrahedral
// mesh of every material, the particles and a report out. The CLI's `cpmesh mesh` is a thin layer over it.
//
//   cpmesh::gpu::Context ctx;                       // any Vulkan 1.2 device; lavapipe without a GPU
//   const auto volume = cpmesh::io::read_label_volume("labels.nrrd");
//   cpmesh::mesh::MeshOptions options;              // defaults for medical segmentations
//   const auto result = cpmesh::mesh::mesh_volume(ctx, volume, options,
//       [](const cpmesh::mesh::StageEvent& e) { if (e.seconds >= 0) std::puts((e.stage + ": " + e.detail).c_str()); });
//   cpmesh::io::write_vtp("interfaces.vtp", result.surfaces);
//   cpmesh::io::write_vtu("volume.vtu", result.volume);
//
// Stages (the names in MeshReport::seconds): "fields" (indicator fields, embedding, sizing) -> "seeding" ->
// "advection" (with add/delete rounds, then the junction protection) -> "delaunay and extraction" (Delaunay of the
// particles on every core, delaunay.h; tet labels, repair, interface triangles) -> "smoothing" (smooth.h) ->
// "quality" -> "volume mesh" (per material, or per piece of a large material: TetGen -pqAY bounded by its interface
// triangles, then the sliver passes; volume_mesh.h).
// Three stages also report their steps (MeshReport::steps): "fields" = "indicator fields" + "embedding" + "sizing
// field" (and a little unmeasured work between them); "delaunay and extraction" = "tetrahedralization" (the
// Delaunay and the tets' adjacency, then the repair's point insertions into it: DelaunayMesh) + "extraction"
// (the rest: the point list, tet labels, repair, interface triangles); "volume mesh" = "region seeds" (a
// seed point per material component) + "cutting into pieces" + "TetGen runs" + "merge and seams" (volume_mesh.h) +
// "interface vertex moves" (surface_slivers.h, with the interfaces' figures measured again after them) + "output and
// statistics" (the output's numbering, physical units and tet quality).
#include <array>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "fields/fields_stage.h"
#include "io/mesh.h"
#include "io/volume.h"
#include "mesh/quality.h"
#include "mesh/small_labels.h"
#include "mesh/well_composed.h"
#include "mesh/smooth.h"
#include "mesh/surface_slivers.h"
#include "mesh/volume_mesh.h"
#include "mesh/interface_collapses.h"
#include "mesh/interface_flips.h"
#include "mesh/label_volumes.h"
#include "mesh/tetgen.h"
#include "particles/population.h"

namespace cpmesh::mesh {

struct MeshOptions {
  fields::FieldsOptions fields;
  particles::AdvectionOptions advection;
  particles::PopulationOptions population;
  QualityOptions volume;
  bool only_surfaces = false;  // skip the volume mesh
  double junction_protection = 0.55;  // interface particles closer than this x h to a bounding triple curve or
                                      // quadruple point are left out of the mesh (particles::protect_junctions)
  SmoothOptions smoothing;     // of the interface meshes after extraction (smooth.h)
  CollapseOptions collapses;   // after the first smoothing (interface_collapses.h; passes 0: off)
  FlipOptions flips;           // between two smoothings, where flips were made (interface_flips.h; passes 0: off)
  LabelVolumeOptions label_volumes;  // labels grown or shrunk to their voxel volume, last (label_volumes.h)
  int repair_rounds = 24;      // rounds of Delaunay refinement where wrong faces or non-manifold interface edges
                               // are left (refine.h); each adds samples only where there is room
  // Labels with fewer voxels join the label they touch most (small_labels.h); report.json lists them. 0 or 1: all kept.
  int64_t min_label_voxels = 8;
  // Join the label map's edge-only and corner-only pairs of voxels across a face before the fields
  // (well_composed.h); report.json says how many voxels changed. Without it noisy-48's saddles at such pairs leave
  // wrong faces (docs/corpus.md, "Well-composed labels").
  bool well_composed = true;
  // Materials to mesh (empty: every label). Each group keeps its first label and merges the others into it; labels in
  // no group become 0, the background. A label not in the volume is an error.
  std::vector<std::vector<uint16_t>> materials;
  // Particles the seeding may make before the run stops with an error (0: no limit). The particle count is set by the
  // sizing field, and thin layers ask for h at --min-size: a 1-voxel shell at 128^3 seeds 400k particles, hours of
  // advection on a CPU device. Stopping after seeding, with the count, beats a run that looks hung.
  size_t max_particles = 5'000'000;
};

// Materials (labels and the outside) a volume may have: material indices are 16-bit, below MaterialSet::kNone.
constexpr size_t kMaxMaterials = fields::MaterialSet::kNone;
// Throws std::invalid_argument naming the volume's source when it has more materials than that (`census`: its
// voxels per label, small_labels.h).
void check_label_limit(const io::LabelVolume& volume, const LabelCensus& census);

// The volume with options.materials applied (a copy); throws std::invalid_argument naming a missing label.
io::LabelVolume select_materials(const io::LabelVolume& volume, const std::vector<std::vector<uint16_t>>& groups);

struct InterfaceReport {
  std::array<uint16_t, 2> labels{};
  TriangleStats quality;
  SurfaceCheck check;
};

struct MaterialReport {
  uint16_t label = 0;
  size_t boundary_triangles = 0;
  size_t odd_edges = 0;  // 0: its boundary is closed
  TetStats tets;         // of the volume mesh
};

// A step within a stage (MeshReport::steps): its time is part of the stage's.
struct StepTime {
  std::string stage, step;
  double seconds = 0;
};

// Where the Delaunay refinement stopped with a face still to refine: the face's two labels and where it is
// (physical units), as the error names them.
struct RefinementLeft {
  std::array<uint16_t, 2> labels{};
  std::array<double, 3> at{};
};

struct MeshReport {
  std::vector<std::pair<std::string, double>> seconds;  // per stage
  std::vector<DroppedLabel> dropped_labels;             // labels under MeshOptions::min_label_voxels
  WellComposedReport well_composed;                     // MeshOptions::well_composed
  std::vector<StepTime> steps;                          // the parts of "fields", "delaunay and extraction", "volume mesh"
  std::array<int64_t, 3> face_padding{0, 0, 0};  // voxels of label 0 added on each side (fields::close_at_faces)
  int subcells = 0;        // the closest point embedding's, as chosen (fields::resolve_fields_options)
  std::string one_subcell_because;  // fields::DeviceFields: two subcells would not fit the device
  double band_voxels = 0;  // the indicator fields' band, as chosen
  size_t particles = 0, rounds = 0;
  size_t protected_particles = 0;  // interface particles left out near junctions (MeshOptions::junction_protection)
  size_t off_feature_particles = 0;  // particles left out for lying off their feature (particles::drop_off_feature),
                                     // between the rounds and after the last
  size_t crowded_particles = 0;  // particles left out for crowding a neighbour on their feature (particles::thin_crowded)
  int iterations = 0;
  bool settled = false, steady = false;
  size_t delaunay_tets = 0;
  size_t wrong_faces_before_repair = 0, relabelled_tets = 0, wrong_faces = 0;  // extract.h "Repair"
  size_t refinement_points = 0;  // samples the Delaunay refinement added (refine.h)
  size_t refinement_moves = 0;   // particles on the wrong feature moved to a refinement sample
  size_t refinement_removals = 0;  // particles on the wrong feature with no junction to move to, left out
  int refinement_rounds = 0;
  size_t mend_edges = 0, mend_relabelled = 0;  // after the refinement (mend_topology.h): fault edges, tets relabelled
  size_t junction_vertices = 0;  // vertices taken onto junctions within the crowding radius (extract.h, promote_...)
                                 // or, where wrong faces were left after the mend, within half a voxel
                                 // (refine.h, wrong_vertex_junctions)
  std::vector<RefinementLeft> refinement_left;  // the first kMaxRefinementLeft faces left to refine
  size_t smoothing_moves = 0;  // accepted vertex moves of the interface smoothing
  size_t interface_collapses = 0;  // edges collapsed inside the interfaces (interface_collapses.h)
  size_t interface_flips = 0;  // edges flipped inside one interface (interface_flips.h)
  LabelVolumeReport label_volumes;  // MeshOptions::label_volumes
  TriangleStats surface;  // all interface triangles
  TriangleStats junction_triangles, other_triangles;  // with a triple-curve or quadruple-point vertex; without
  std::vector<InterfaceReport> interfaces;
  std::vector<MaterialReport> materials;
  TetStats volume;           // the whole volume mesh
  TetImproveReport tet_improvement;  // the sliver passes after TetGen (smooth.h improve_tets, both runs)
  SliverSplitReport sliver_split;    // slivers flipped away or refilled around a new vertex (smooth.h split_slivers)
  SurfaceSliverReport surface_slivers;  // slivers mended by moving interface vertices (surface_slivers.h)
  std::string volume_error;  // why the volume mesh was not made (empty: made, or not asked)
  std::string volume_one_run_because;  // not empty: why the materials were meshed in one run (volume_mesh.h)
  std::vector<MaterialRunTiming> volume_runs;  // time of each TetGen run and its sliver passes (volume_mesh.h)
  std::vector<std::string> volume_unsplit_because;  // materials asked to be cut into pieces but meshed whole, why
  size_t volume_separator_points = 0;               // points of the pieces' separators (split_material.h)
  size_t interfaces_manifold = 0, materials_closed = 0;
  size_t crossing_triangles = 0;  // pairs of interface triangles that cross each other (quality.h; 0 for a valid mesh)
  // Tet faces and interface triangles that disagree (quality.h nonconforming_faces; 0 for a valid mesh), the first
  // one's place in physical units.
  size_t nonconforming_faces = 0;
  std::array<double, 3> nonconforming_at{};
};

constexpr size_t kMaxRefinementLeft = 20;

// What keeps the mesh from the guarantee (docs/design.md, "The guarantee"): wrong faces left, interfaces that are
// not manifold or whose boundary leaves the triple curves, materials not closed, crossing triangles, tets whose
// materials disagree with the interface triangles; one line each,
// naming the labels and where. Empty for a valid mesh. The CLI exits non-zero when it is not empty.
std::vector<std::string> guarantee_failures(const MeshReport& report);

struct MeshResult {
  io::TriangleMesh surfaces;   // every interface, physical units, triangle_pair = labels (normal into the second)
  io::TetMesh volume;          // tets with their labels, plus the interface triangles; empty with only_surfaces
  io::TriangleMesh particles;  // the settled particles as points (feature kind, sizing)
  MeshReport report;
};

// What mesh_volume reports as it goes, per stage (the names in MeshReport::seconds): once when the stage starts
// (seconds < 0, detail empty), any number of times while it runs (seconds < 0, detail: how far it is, e.g. the
// advection's rounds), and once when it ends (seconds >= 0, detail: what it made).
struct StageEvent {
  std::string stage;
  int index = 0, count = 0;  // this stage's number (1-based) and how many stages the run has
  std::string detail;
  double seconds = -1;
};
using StageCallback = std::function<void(const StageEvent&)>;

// Thrown when the seeding makes more than MeshOptions::max_particles particles.
struct ParticleBudgetError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

MeshResult mesh_volume(gpu::Context& ctx, const io::LabelVolume& volume, const MeshOptions& options = {},
                       const StageCallback& on_stage = {});

}  // namespace cpmesh::mesh
