// The realistic corpus through the real binaries, checked by the independent checker on the written files
// (docs/design.md, "The guarantee"): a mesh that holds it exits 0 and passes cpmesh-check; one that does not exits 1,
// names what failed and where, and says so in report.json.
#include <doctest/doctest.h>

#include <chrono>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "cli/run_tool.h"
#include "scratch_dir.h"

using cpmesh::test::contains;
using cpmesh::test::run_tool;

namespace {

std::string corpus_file(const std::string& name) {
  const auto path = cpmesh::test::scratch_dir("corpus") / (name + ".nrrd");
  REQUIRE(run_tool("cpmesh-synth --corpus " + name + " -o " + path.string()).exit_code == 0);
  return path.string();
}

// A value the checker printed as "  name   value" (it measures every check, judged or not).
double measured(const std::string& check_output, const std::string& name) {
  const size_t at = check_output.find("  " + name + " ");
  REQUIRE(at != std::string::npos);
  return std::stod(check_output.substr(at + name.size() + 2));
}

nlohmann::json read_json(const std::filesystem::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

}  // namespace

const std::string kGuaranteeChecks = "interfaces,closure,wrong\\ faces,crossings,conformity,labels";
// The guarantee and item 6's quality (no tet under 10 degrees, interface radius ratio mean at least 0.93, min 0.2).
const std::string kGuaranteeAndQuality = kGuaranteeChecks + ",quality";

// Meshes a corpus volume at default settings into `out` and asserts the guarantee as the independent checker reads
// the written files (`checks`; empty: every check, quality included); returns the report and the checker's output.
std::pair<nlohmann::json, std::string> mesh_holding_the_guarantee(const std::string& volume,
                                                                  const std::filesystem::path& out,
                                                                  const std::string& checks = kGuaranteeChecks) {
  const auto r = run_tool("cpmesh mesh " + volume + " -o " + out.string());
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  const auto report = read_json(out / "report.json");
  CHECK(report["valid"] == true);
  const auto check = run_tool("cpmesh-check --volume " + volume + " --surfaces " + (out / "interfaces.vtp").string() +
                              " --tets " + (out / "volume.vtu").string() + (checks.empty() ? "" : " --only " + checks));
  INFO(check.output);
  CHECK(check.exit_code == 0);
  return {report, check.output};
}

TEST_CASE("corpus islands-48: islands, pockets and a two-voxel label pass every check of the checker, quality included") {
  // docs/design.md, "Small islands": held away from 0 at their voxel centres (--island-margin), the small islands
  // keep their shape and their tets are no slivers (with --island-margin 0: 19 tets under 10 degrees, radius ratio
  // min 0.06).
  const std::string volume = corpus_file("islands-48");
  const auto [report, check] = mesh_holding_the_guarantee(volume, cpmesh::test::scratch_dir("islands"), "");
  // The two-voxel label 5 is under --min-label-voxels' default of 8: listed, and merged into what it touches most.
  REQUIRE(report["dropped_labels"].size() == 1);
  CHECK(report["dropped_labels"][0]["label"] == 5);
  CHECK(report["dropped_labels"][0]["voxels"] == 2);
  CHECK(measured(check, "manifold_interfaces") == 4);  // 0/1, 0/2, 1/2, 1/3
  CHECK(measured(check, "tets_below_min_dihedral") == 0);
}

TEST_CASE("corpus organs-64: tubes with one- and two-voxel walls, anisotropic voxels, labels on the volume's faces") {
  // The vessel walls are thinner than the particles' spacing asks for at the walls' edges on the volume's faces; the
  // refinement samples them below h (refine.h) until the interfaces are manifold.
  const std::string volume = corpus_file("organs-64");
  const auto [report, check] = mesh_holding_the_guarantee(volume, cpmesh::test::scratch_dir("organs"));
  CHECK(report["repair"]["refinement_points"].get<int>() > 0);
  CHECK(contains(check, "labels_missing               0"));
  // Its slivers had four interface vertices across the walls: with the particles crowded into the thin lumens
  // thinned (particles::thin_crowded; without it 7 tets under 10 degrees, down to 1.8), the interface smoothing's
  // shape target and the interface vertex moves (surface_slivers.h) where any are left, none is under 10 degrees.
  CHECK(report["crowded_particles"].get<int>() > 0);
  CHECK(measured(check, "tets_below_min_dihedral") == 0);
  CHECK(measured(check, "min_dihedral") >= 10);
  // The smoothing's shape target (smooth.h): 0.956 (0.941 with the area-weighted centroid).
  CHECK(measured(check, "radius_ratio_mean") >= 0.95);
  // Label volumes (label_volumes.h): the vessels (193 to 886 voxels) and the organ (4,978) came out 2.4-7.0% off their
  // voxels (the rounding of the fields and the chords of the triangles); moved to their voxel volume they are within
  // 0.01%, and every label of at least 100 voxels within 1.5%, tets and all (the body, inside the pass's 1% tolerance
  // and left alone, gives up what the vessels gain: 0.74% under).
  const auto out = cpmesh::test::scratch_dir("organs");
  const auto labels = run_tool("cpmesh-check --volume " + volume + " --surfaces " + (out / "interfaces.vtp").string() +
                               " --tets " + (out / "volume.vtu").string() +
                               " --only labels --volume-min-voxels 100 --volume-tolerance 0.015");
  INFO(labels.output);
  CHECK(labels.exit_code == 0);
  CHECK(report["label_volumes"]["labels_moved"].get<int>() >= 5);
}

TEST_CASE("corpus parcellation-48: 40 labels whose staircase meets four and more at voxel edges and corners") {
  // docs/design.md, "Junctions closer than the crowding radius": without the junction rules the refinement left 22
  // wrong faces at three such places (exit 1), and a cluster of quadruple points made tets of 0.2 degrees.
  const std::string volume = corpus_file("parcellation-48");
  // Most of its triangles touch a junction: the smoothing's shape target and the edge flips between two smoothings
  // (interface_flips.h) lift them to 0.936 (0.933 without the flips, 0.915 with the area-weighted centroid), and the
  // collapses of the short edges the refinement leaves there (interface_collapses.h) a little more; its last sliver
  // had four interface vertices across a thin part, mended off the interface (surface_slivers.h).
  const auto [report, check] =
      mesh_holding_the_guarantee(volume, cpmesh::test::scratch_dir("parcellation"), kGuaranteeAndQuality);
  CHECK(report["repair"]["junction_vertices"].get<int>() > 0);
  CHECK(report["interface_flips"].get<int>() > 0);
  CHECK(report["interface_collapses"].get<int>() > 0);
  CHECK(measured(check, "wrong_faces") == 0);
  CHECK(measured(check, "labels_missing") == 0);
  CHECK(measured(check, "min_dihedral") >= 10);
}

TEST_CASE("corpus noisy-48: flipped voxels and anisotropic spacing hold the guarantee after the well-composed repair") {
  // docs/design.md, "Well-composed labels": the flipped voxels leave edge- and corner-only pairs whose saddles the
  // particles cannot resolve; joined across a face first, every interface is manifold (without: exit 1, 30 of 33
  // interfaces manifold, 50 wrong faces).
  const std::string volume = corpus_file("noisy-48");
  // Quality too: radius ratio mean 0.934 with the edge flips (0.930 without), smallest angle 12 degrees with the
  // surface vertices let off the interface across thin parts (6.7 without).
  const auto [report, check] =
      mesh_holding_the_guarantee(volume, cpmesh::test::scratch_dir("noisy-valid"), kGuaranteeAndQuality);
  const auto& label_map = report["label_map"];
  CHECK(label_map["well_composed_repair"] == true);
  CHECK(label_map["critical_configurations"].get<int>() > 0);
  CHECK(label_map["voxels_changed"].get<int>() > 0);
  CHECK(label_map["critical_configurations_left"].get<int>() < label_map["critical_configurations"].get<int>());
  CHECK(measured(check, "wrong_faces") == 0);
  CHECK(measured(check, "manifold_interfaces") == measured(check, "interfaces"));
  CHECK(measured(check, "labels_missing") == 0);
}

TEST_CASE("corpus thin-48: one-voxel sheets and tubes between and across layers hold the guarantee") {
  // Where the one-voxel falx thins under the skull the refinement stalls with its 10/40 interface pinched (edges in
  // four triangles) and wrong faces at its front edge; relabelling runs of tets around them mends them
  // (mend_topology.h; without it 17 of 19 interfaces manifold, exit 1).
  const std::string volume = corpus_file("thin-48");
  const auto [report, check] = mesh_holding_the_guarantee(volume, cpmesh::test::scratch_dir("thin") / "out");
  CHECK(report["repair"]["mend_relabelled_tets"].get<int>() > 0);
  CHECK(measured(check, "manifold_interfaces") == measured(check, "interfaces"));
  CHECK(measured(check, "labels_missing") == 0);
  // Item 6 is not met here: 7 tets under 10 degrees (3.2) where the falx's sides meet at a pinch (81, down to 0.46,
  // before the surface vertices could leave the interface; docs/corpus.md). 20 guards against that coming back.
  CHECK(measured(check, "tets_below_min_dihedral") <= 20);
  CHECK(measured(check, "radius_ratio_mean") >= 0.95);
}

TEST_CASE("the label map as given: --no-well-composed leaves it and says so") {
  const std::string volume = corpus_file("noisy-48");
  const auto out = cpmesh::test::scratch_dir("noisy-as-given");
  const auto r = run_tool("cpmesh mesh " + volume + " --only-surfaces --no-well-composed -o " + out.string());
  INFO(r.output);
  const auto label_map = read_json(out / "report.json")["label_map"];
  CHECK(label_map["well_composed_repair"] == false);
  CHECK(label_map["voxels_changed"] == 0);
}

TEST_CASE("a mesh that breaks the guarantee is an error that names the interfaces and places, never exit 0") {
  const std::string volume = corpus_file("noisy-48");
  const auto out = cpmesh::test::scratch_dir("noisy");
  // Without refinement the particles' restricted Delaunay of this noisy 12-label volume has wrong faces.
  const auto r = run_tool("cpmesh mesh " + volume + " --only-surfaces --refinement-rounds 0 -o " + out.string());
  INFO(r.output);
  CHECK(r.exit_code == 1);
  CHECK(contains(r.output, "the mesh is not valid"));
  CHECK(contains(r.output, "wrong faces left after refinement"));
  CHECK(contains(r.output, "faces the refinement could not mend: "));
  const auto report = read_json(out / "report.json");
  CHECK(report["valid"] == false);
  CHECK(!report["invalid_because"].empty());
  CHECK(!report["repair"]["left"].empty());
  // The checker agrees that the written mesh is broken.
  const auto check = run_tool("cpmesh-check --surfaces " + (out / "interfaces.vtp").string() + " --only interfaces,wrong\\ faces");
  CHECK(check.exit_code == 1);
}

TEST_CASE("corpus parcellation-300-32: 300 labels hold the guarantee, every label of 8 voxels or more kept") {
  // Far beyond 64 materials (the material sets are 16-bit slots, docs/design.md "Materials"), and junctions of up
  // to five labels at voxel corners (docs/design.md, "Junctions closer than the crowding radius").
  const std::string volume = corpus_file("parcellation-300-32");
  const auto out = cpmesh::test::scratch_dir("many") / "out";
  const auto report = mesh_holding_the_guarantee(volume, out).first;
  size_t dropped = 0;
  for (const auto& d : report["dropped_labels"]) {
    CHECK(d["voxels"].get<int>() < 8);
    ++dropped;
  }
  CHECK(report["materials"].size() + dropped == 301);  // every label and the outside, kept or listed
  CHECK(report["materials"].size() > 250);
  const auto check = run_tool("cpmesh-check --volume " + volume + " --surfaces " + (out / "interfaces.vtp").string() +
                              " --tets " + (out / "volume.vtu").string() + " --only labels --json " +
                              (out / "check.json").string());
  INFO(check.output);
  CHECK(check.exit_code == 0);
  const auto measured = read_json(out / "check.json");
  CHECK(measured["values"]["labels"] == 300);
  CHECK(measured["values"]["labels_missing"] == 0);
  // No tet under 10 degrees (12 before the surface vertices could leave their features, docs/corpus.md). The radius
  // ratio mean (0.868) is not item 6's, most triangles here touch a junction; its minimum is, with the vertices of
  // the flat triangles moved (surface_slivers.h, --min-triangle-ratio; 0.166 without: two quadruple points 0.37 and
  // 0.68 voxel from a curve vertex, nearly in a line).
  CHECK(measured["values"]["min_dihedral"].get<double>() >= 10);
  CHECK(measured["values"]["radius_ratio_min"].get<double>() >= 0.2);
}

TEST_CASE("a volume over the material limit fails at once, naming the file and the limit, and writes nothing") {
  // Every 16-bit label value, one voxel each: 65536 materials, one more than the material index allows.
  const auto volume = cpmesh::test::scratch_dir("limit") / "every-label.nrrd";
  {
    std::ofstream f(volume, std::ios::binary);
    f << "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 64 32 32\nencoding: raw\nendian: little\n\n";
    for (uint32_t v = 0; v < 65536; ++v) f.put(char(v & 0xff)).put(char(v >> 8));
  }
  const auto out = cpmesh::test::scratch_dir("many-limit") / "out";
  const auto start = std::chrono::steady_clock::now();
  // --min-label-voxels 0 keeps every label.
  const auto r = run_tool("cpmesh mesh " + volume.string() + " --min-label-voxels 0 -o " + out.string());
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  CHECK(r.exit_code == 1);
  CHECK(contains(r.output, volume.string() + ": 65536 materials"));
  CHECK(contains(r.output, "at most 65535"));
  CHECK(seconds < 30);  // a bound on a hang, not a timing
  CHECK(!std::filesystem::exists(out));
}
