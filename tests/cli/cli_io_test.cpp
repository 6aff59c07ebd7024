// `cpmesh info` and `cpmesh-synth` run as a user would: output, exit codes, and clear errors on bad input.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/run_tool.h"
#include "io/mesh_readers.h"
#include "mesh/quality.h"

using cpmesh::test::contains;
using cpmesh::test::run_tool;
namespace fs = std::filesystem;

namespace {
const std::string asset = std::string(CPMESH_SOURCE_DIR) + "/assets/wedge_ball_48.nrrd";

fs::path scratch() {
  const fs::path dir = fs::temp_directory_path() / ("cpmesh_cli_io_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}
}  // namespace

TEST_CASE("info on the bundled wedge ball: 5 labels and their neighbours") {
  const auto r = run_tool("cpmesh info " + asset);
  REQUIRE(r.exit_code == 0);
  CHECK(contains(r.output, "48 x 48 x 48"));
  CHECK(contains(r.output, "labels   5"));
  // label 0 touches the wedges but never the inner ball; 4 touches only the wedges.
  CHECK(contains(r.output, "1 2 3\n"));
  CHECK(contains(r.output, "0 2 3 4\n"));
  CHECK(contains(r.output, "0 1 3 4\n"));
  CHECK(contains(r.output, "0 1 2 4\n"));
}

TEST_CASE("info on bad input: the file, what was expected, exit code 1, no crash") {
  const auto dir = scratch();
  const auto missing = run_tool("cpmesh info " + (dir / "nope.nrrd").string());
  CHECK(missing.exit_code == 1);
  CHECK(contains(missing.output, "nope.nrrd"));
  const auto directory = run_tool("cpmesh info " + dir.string());
  CHECK(directory.exit_code == 1);
  CHECK(contains(directory.output, "directory"));
  {
    std::ofstream f(dir / "truncated.nrrd", std::ios::binary);
    f << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 10 10 10\nencoding: raw\n\n" << std::string(50, '\1');
  }
  const auto truncated = run_tool("cpmesh info " + (dir / "truncated.nrrd").string());
  CHECK(truncated.exit_code == 1);
  CHECK(contains(truncated.output, "truncated.nrrd"));
  CHECK(contains(truncated.output, "1000"));  // the expected voxel count or byte size is named
  {
    std::ofstream f(dir / "float.nrrd", std::ios::binary);
    f << "NRRD0004\ntype: float\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n\n" << std::string(4, '\0');
  }
  const auto floats = run_tool("cpmesh info " + (dir / "float.nrrd").string());
  CHECK(floats.exit_code == 1);
  CHECK(contains(floats.output, "type"));
  const auto usage = run_tool("cpmesh info");
  CHECK(usage.exit_code != 0);
  fs::remove_all(dir);
}

TEST_CASE("cpmesh-synth writes a volume that info reads back, atomically") {
  const auto dir = scratch();
  const auto out = dir / "shells.nrrd";
  const auto r = run_tool("cpmesh-synth shells --size 32 -o " + out.string());
  REQUIRE(r.exit_code == 0);
  CHECK(fs::exists(out));
  for (const auto& e : fs::directory_iterator(dir)) CHECK(e.path().string().find(".tmp-") == std::string::npos);
  const auto info = run_tool("cpmesh info " + out.string());
  CHECK(info.exit_code == 0);
  CHECK(contains(info.output, "32 x 32 x 32"));
  const auto bad = run_tool("cpmesh-synth cube --size 32 -o " + (dir / "x.nrrd").string());
  CHECK(bad.exit_code != 0);
  CHECK(!fs::exists(dir / "x.nrrd"));
  fs::remove_all(dir);
}

TEST_CASE("cpmesh-synth lists the corpus and writes its volumes by name") {
  const auto dir = scratch();
  const auto list = run_tool("cpmesh-synth --list");
  REQUIRE(list.exit_code == 0);
  CHECK(contains(list.output, "parcellation-300: parcellation -n 72 --labels 300"));
  CHECK(contains(list.output, "organs-438: organs -n 438"));
  const auto out = dir / "thin.nrrd";
  REQUIRE(run_tool("cpmesh-synth --corpus islands-48 -o " + out.string()).exit_code == 0);
  const auto info = run_tool("cpmesh info " + out.string());
  CHECK(contains(info.output, "label 5 has only 2 voxels"));
  const auto unknown = run_tool("cpmesh-synth --corpus nope -o " + out.string());
  CHECK(unknown.exit_code == 1);
  CHECK(contains(unknown.output, "field 'corpus': expected one of parcellation-48"));
  CHECK(run_tool("cpmesh-synth thin --corpus thin-48 -o " + out.string()).exit_code == 1);
  fs::remove_all(dir);
}

TEST_CASE("fields on the bundled wedge ball: features found, files written, errors clear") {
  const auto dir = scratch();
  const auto out = dir / "fields";
  const auto r = run_tool("cpmesh fields " + asset + " -o " + out.string());
  REQUIRE(r.exit_code == 0);
  CHECK(contains(r.output, "5 materials, 9 interfaces, 8 triple curves, 4 quadruple points"));
  for (const char* f : {"indicator_0.nrrd", "indicator_4.nrrd", "sizing.nrrd", "embedding.vtp", "fields.json"})
    CHECK(fs::exists(out / f));
  const auto info = run_tool("cpmesh info " + (out / "sizing.nrrd").string());
  CHECK(info.exit_code == 1);  // a float field is not a label volume: refused with a message
  CHECK(contains(info.output, "sizing.nrrd"));
  const auto bad = run_tool("cpmesh fields " + (dir / "missing.nrrd").string() + " -o " + out.string());
  CHECK(bad.exit_code == 1);
  CHECK(contains(bad.output, "missing.nrrd"));
  fs::remove_all(dir);
}

TEST_CASE("particles on a small sphere: settled population written, parameters in --help, errors clear") {
  const auto dir = scratch();
  const auto vol = dir / "sphere.nrrd";
  REQUIRE(run_tool("cpmesh-synth sphere --size 32 --radius 10 -o " + vol.string()).exit_code == 0);
  const auto out = dir / "particles";
  const auto r = run_tool("cpmesh particles " + vol.string() + " --max-size 2.5 -o " + out.string());
  REQUIRE(r.exit_code == 0);
  CHECK(contains(r.output, "round"));
  CHECK(fs::exists(out / "particles.vtp"));
  std::ifstream json(out / "particles.json");
  const auto j = nlohmann::json::parse(json);
  // Hexagonal packing at h = 2.5 on a sphere of radius 10: 4 pi 100 / (sqrt(3)/2 6.25) = 232 particles.
  CHECK(j["particles"].get<double>() == doctest::Approx(232.0).epsilon(0.1));
  CHECK(j["rounds"].size() >= 1);
  const auto help = run_tool("cpmesh particles --help");
  for (const char* opt : {"--readd-factor", "--delete-factor", "--add-factor", "--seed-constant", "--seed-energy"})
    CHECK(contains(help.output, opt));
  CHECK(contains(help.output, "4"));
  const auto bad = run_tool("cpmesh particles " + (dir / "missing.nrrd").string() + " -o " + out.string());
  CHECK(bad.exit_code == 1);
  CHECK(contains(bad.output, "missing.nrrd"));
  fs::remove_all(dir);
}

TEST_CASE("mesh on a small sphere: interface, volume mesh, particles and report written; errors clear") {
  const auto dir = scratch();
  const auto vol = dir / "sphere.nrrd";
  REQUIRE(run_tool("cpmesh-synth sphere --size 32 --radius 10 -o " + vol.string()).exit_code == 0);
  const auto out = dir / "mesh";
  const auto r = run_tool("cpmesh mesh " + vol.string() + " --max-size 2.5 --format ply --volume-runs 3 -o " +
                          out.string() + " --preview " + (dir / "preview.png").string());
  REQUIRE(r.exit_code == 0);
  CHECK(fs::file_size(dir / "preview.png") > 1000);
  CHECK(contains(r.output, "volume mesh:"));
  for (const char* f : {"interfaces.ply", "interface_0_1.ply", "volume.vtu", "particles.vtp", "report.json"})
    CHECK(fs::exists(out / f));
  std::ifstream json(out / "report.json");
  const auto j = nlohmann::json::parse(json);
  CHECK(j["interfaces"].size() == 1);
  CHECK(j["interfaces"][0]["manifold"].get<bool>());
  CHECK(j["materials"][0]["closed"].get<bool>());
  CHECK(j["surface"]["mean_radius_ratio"].get<double>() > 0.85);
  CHECK(j["volume_mesh"]["tets"].get<int>() > 0);
  // 3 runs asked, but a boundary of a few thousand triangles is not cut (QualityOptions::min_piece_triangles).
  REQUIRE(j["volume_mesh"]["runs"].size() == 1);
  CHECK(j["volume_mesh"]["runs"][0]["pieces"] == 1);
  // TetGen started from interior points (on by default), and kept them: they are among the points the run added.
  CHECK(j["volume_mesh"]["runs"][0]["interior_points"].get<size_t>() > 0);
  CHECK(j["volume_mesh"]["runs"][0]["interior_points"].get<size_t>() <= j["volume_mesh"]["runs"][0]["added_points"].get<size_t>());
  CHECK(j["volume_mesh"]["separator_points"] == 0);
  {
    // The worst tet named in the report is the cell of volume.vtu with the smallest dihedral angle, where it says.
    const auto vtu = cpmesh::io::read_vtu((out / "volume.vtu").string());
    const auto& v = j["volume_mesh"];
    const size_t worst = v.at("worst_tet").get<size_t>();
    REQUIRE(worst < vtu.tets.size());
    auto corner = [&](uint32_t i) { return glm::dvec3(vtu.vertices[i][0], vtu.vertices[i][1], vtu.vertices[i][2]); };
    double smallest = 180;
    size_t first = 0;
    for (size_t t = 0; t < vtu.tets.size(); ++t) {
      const auto& k = vtu.tets[t];
      const double d = cpmesh::mesh::min_dihedral(corner(k[0]), corner(k[1]), corner(k[2]), corner(k[3])) * 180 / M_PI;
      if (d < smallest) {
        smallest = d;
        first = t;
      }
    }
    CHECK(worst == first);
    CHECK(v.at("min_dihedral_deg").get<double>() == doctest::Approx(smallest).epsilon(1e-9));
    const auto& k = vtu.tets[worst];
    const glm::dvec3 centroid = (corner(k[0]) + corner(k[1]) + corner(k[2]) + corner(k[3])) / 4.0;
    for (int a = 0; a < 3; ++a)
      CHECK(v.at("worst_tet_centroid")[size_t(a)].get<double>() == doctest::Approx(centroid[a]).epsilon(1e-9));
    CHECK(contains(r.output, "smallest dihedral angle"));
  }
  // Timings: the read, every stage, and the steps of the three stages that have them, each within its stage.
  CHECK(contains(r.output, "read volume"));
  CHECK(contains(r.output, "    tetrahedralization"));
  for (const char* stage : {"read volume", "fields", "seeding", "advection", "delaunay and extraction", "smoothing",
                            "quality", "volume mesh", "write"})
    CHECK_MESSAGE(j.at("seconds").contains(stage), stage);
  const std::map<std::string, std::vector<std::string>> steps = {
      {"fields", {"indicator fields", "embedding", "sizing field"}},
      {"delaunay and extraction", {"tetrahedralization", "extraction"}},
      {"volume mesh", {"region seeds", "cutting into pieces", "TetGen runs", "merge and seams", "interface vertex moves",
                       "output and statistics"}}};
  for (const auto& [stage, parts] : steps) {
    double sum = 0;
    for (const auto& part : parts) {
      REQUIRE_MESSAGE(j.at("steps").at(stage).contains(part), stage, ": ", part);
      const double s = j.at("steps").at(stage).at(part).get<double>();
      CHECK(s >= 0);
      sum += s;
    }
    CHECK(sum <= j.at("seconds").at(stage).get<double>() + 1e-9);
  }
  {
    // --no-interior-points: TetGen refines from the surface alone; the same surfaces, about as many tets.
    const auto plain_out = dir / "plain";
    const auto plain = run_tool("cpmesh mesh " + vol.string() + " --max-size 2.5 --format ply --no-interior-points -o " +
                                plain_out.string());
    REQUIRE(plain.exit_code == 0);
    std::ifstream plain_json(plain_out / "report.json");
    const auto p = nlohmann::json::parse(plain_json);
    CHECK(p["volume_mesh"]["runs"][0]["interior_points"] == 0);
    CHECK(p["surface"]["triangles"] == j["surface"]["triangles"]);
    const double ratio = p["volume_mesh"]["tets"].get<double>() / j["volume_mesh"]["tets"].get<double>();
    CHECK(ratio > 0.8);
    CHECK(ratio < 1.25);
  }
  const auto bad = run_tool("cpmesh mesh " + vol.string() + " --format xyz -o " + out.string());
  CHECK(bad.exit_code != 0);
  CHECK(contains(bad.output, "xyz"));
  const auto missing = run_tool("cpmesh mesh " + vol.string() + " --materials 1+9 -o " + (dir / "m2").string());
  CHECK(missing.exit_code == 1);
  CHECK(contains(missing.output, "label 9"));
  CHECK(!fs::exists(dir / "m2" / "report.json"));
  const auto garbled = run_tool("cpmesh mesh " + vol.string() + " --materials 1+x -o " + (dir / "m2").string());
  CHECK(garbled.exit_code == 1);
  CHECK(contains(garbled.output, "--materials"));
  const auto budget = run_tool("cpmesh mesh " + vol.string() + " --max-particles 20 -o " + (dir / "m3").string());
  CHECK(budget.exit_code == 1);
  CHECK(contains(budget.output, "sphere.nrrd: seeding made"));
  CHECK(contains(budget.output, "more than the limit of 20"));
  CHECK(!fs::exists(dir / "m3"));
  fs::remove_all(dir);
}

TEST_CASE("cpmesh-bench-pipeline: a table row and a JSON line per volume with every stage and step; errors clear") {
  const auto r = run_tool("cpmesh-bench-pipeline --volumes sphere:28,wedge-ball:32 --no-peer --max-size 2.5 "
                          "--compare-delaunay");
  REQUIRE_MESSAGE(r.exit_code == 0, r.output);
  std::istringstream lines(r.output);
  std::string line, header, sphere_row;
  std::vector<nlohmann::json> rows;
  while (std::getline(lines, line)) {
    if (line.rfind("{\"benchmark\"", 0) == 0) rows.push_back(nlohmann::json::parse(line));
    if (line.rfind("volume ", 0) == 0) header = line;
    if (line.rfind("sphere:28 ", 0) == 0) sphere_row = line;
  }
  // The header names every column, and its columns line up with the rows' (right-aligned: the same length).
  for (const char* head : {"load", "indicator", "embedding", "sizing", "seeding", "advection", "it/rnd", "delaunay",
                           "extract", "smoothing", "quality", "volume", "rr mean", "host MiB", "dev MiB"})
    CHECK_MESSAGE(contains(header, head), head);
  CHECK(!sphere_row.empty());
  CHECK(header.size() == sphere_row.size());
  REQUIRE(rows.size() == 2);
  for (const auto& j : rows) {
    INFO(j.dump());
    double stages = 0;
    for (const char* stage : {"load", "fields", "seeding", "advection", "delaunay and extraction", "smoothing",
                              "quality", "volume mesh"}) {
      REQUIRE(j.at("seconds").contains(stage));
      CHECK(j.at("seconds").at(stage).get<double>() >= 0);
      stages += j.at("seconds").at(stage).get<double>();
    }
    CHECK(stages <= j.at("total_s").get<double>() + 1e-9);
    double fields = 0, delaunay = 0;
    for (const char* step : {"indicator fields", "embedding", "sizing field"}) fields += j.at("steps").at("fields").at(step).get<double>();
    for (const char* step : {"tetrahedralization", "extraction"})
      delaunay += j.at("steps").at("delaunay and extraction").at(step).get<double>();
    CHECK(fields > 0);
    CHECK(fields <= j.at("seconds").at("fields").get<double>() + 1e-9);
    CHECK(delaunay > 0);
    CHECK(delaunay <= j.at("seconds").at("delaunay and extraction").get<double>() + 1e-9);
    CHECK(j.at("particles").get<int>() > 50);
    CHECK(j.at("iterations").get<int>() > 0);
    CHECK(j.at("rounds").get<int>() >= 1);
    CHECK(j.at("tets").get<int>() > 0);
    CHECK(j.at("wrong_faces").get<size_t>() <= j.at("wrong_faces_before_repair").get<size_t>());
    CHECK(j.at("off_feature_particles").get<size_t>() == 0);  // a smooth sphere: every particle on its surface
    CHECK(j.at("protected_particles").is_number_unsigned());
    CHECK(j.at("peak_host_mib").get<double>() > 0);
    CHECK(j.at("peak_device_mib").get<double>() > 0);
    CHECK(j.at("mean_radius_ratio").get<double>() > 0.85);
    CHECK(j.at("min_dihedral_deg").get<double>() > 5);
    // --compare-delaunay: TetGen and the parallel Delaunay on the run's particles (curve points added by the repair
    // among them): the same tetrahedralization.
    const auto& d = j.at("delaunay_compare");
    CHECK(d.at("points").get<size_t>() >= j.at("particles").get<size_t>());
    CHECK(d.at("tetgen_tets").get<size_t>() > d.at("points").get<size_t>());
    CHECK(d.at("parallel_tets") == d.at("tetgen_tets"));
    CHECK(d.at("fell_back") == false);
    CHECK(d.at("threads").get<int>() >= 1);
  }
  CHECK(contains(r.output, "Delaunay of its"));
  CHECK(rows[1].contains("junction_error"));  // the wedge ball's analytic triple curves
  CHECK(!rows[0].contains("junction_error"));
  // Scaling: a run per largest h, then each stage's exponent against the particle count.
  const auto sweep = run_tool("cpmesh-bench-pipeline --volumes sphere:28 --no-peer --only-surfaces --sweep-max-size 4,1.5");
  REQUIRE_MESSAGE(sweep.exit_code == 0, sweep.output);
  CHECK(contains(sweep.output, "sphere:28 h1.5"));
  CHECK(contains(sweep.output, "exponent k, t ~ n^k"));
  nlohmann::json scaling;
  std::istringstream sweep_lines(sweep.output);
  size_t runs = 0;
  while (std::getline(sweep_lines, line)) {
    if (line.rfind("{\"benchmark\":\"pipeline_scaling\"", 0) == 0) scaling = nlohmann::json::parse(line);
    runs += line.rfind("{\"benchmark\":\"pipeline\"", 0) == 0;
  }
  CHECK(runs == 2);
  CHECK(!contains(sweep.output, "delaunay_compare"));  // only when asked
  REQUIRE(scaling.is_object());
  INFO(scaling.dump());
  REQUIRE(scaling.at("rows").size() == 2);
  CHECK(scaling.at("rows")[0].at("max_size").get<double>() == 4.0);
  // A smaller h, more particles (about (4 / 1.5)^2 as many on a surface).
  CHECK(scaling.at("rows")[1].at("particles").get<double>() > 3 * scaling.at("rows")[0].at("particles").get<double>());
  for (const char* key : {"indicator fields", "embedding", "sizing field", "seeding", "advection", "advection iteration",
                          "tetrahedralization", "extraction", "smoothing", "quality", "total"})
    CHECK_MESSAGE(scaling.at("exponents").at(key).is_number(), key);  // fitted (its value is timing: not tested)
  CHECK(!scaling.at("exponents").contains("volume mesh"));  // --only-surfaces: in no row

  // --repeat: each volume run again, then a summary of the runs (the CGAL peer's part where it was built and ran).
  const auto twice = run_tool("cpmesh-bench-pipeline --volumes sphere:28 --no-peer --only-surfaces --repeat 2");
  REQUIRE_MESSAGE(twice.exit_code == 0, twice.output);
  nlohmann::json summary;
  std::vector<double> totals;
  std::istringstream twice_lines(twice.output);
  while (std::getline(twice_lines, line)) {
    if (line.rfind("{\"benchmark\":\"pipeline_repeat\"", 0) == 0) summary = nlohmann::json::parse(line);
    if (line.rfind("{\"benchmark\":\"pipeline\"", 0) == 0)
      totals.push_back(nlohmann::json::parse(line).at("total_s").get<double>());
  }
  REQUIRE(totals.size() == 2);
  REQUIRE(summary.is_object());
  INFO(summary.dump());
  CHECK(summary.at("runs") == 2);
  CHECK(summary.at("total_s").get<std::vector<double>>() == totals);
  CHECK(summary.at("median_s").get<double>() == doctest::Approx(0.5 * (totals[0] + totals[1])));
  CHECK(!summary.contains("median_ratio"));  // --no-peer
  CHECK(contains(twice.output, "sphere:28: 2 runs, median"));
  CHECK(run_tool("cpmesh-bench-pipeline --volumes sphere:28 --no-peer --repeat 0").exit_code != 0);

  // Every spec is checked before the first run.
  for (const auto& [volumes, says] : std::vector<std::pair<std::string, std::string>>{
           {"sphere:24,cube:32", "volume 'cube:32': field 'shape'"}, {"sphere:24,sphere:x", "volume 'sphere:x': field 'size'"},
           {"sphere:24,sphere:3000", "4..2048"}, {"sphere:24,nosuch.nrrd", "nosuch.nrrd"}}) {
    const auto bad = run_tool("cpmesh-bench-pipeline --no-peer --volumes " + volumes);
    CHECK(bad.exit_code == 1);
    CHECK_MESSAGE(contains(bad.output, says), bad.output);
    CHECK(!contains(bad.output, "{\"benchmark\""));
  }
}
