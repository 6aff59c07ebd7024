// cpmesh-synth: writes a synthetic labeled volume with known answers (DESIGN.md) and, for the wedge ball, its analytic
// triple curves and quadruple points as JSON.
#include <iostream>

#include <CLI/CLI.hpp>

#include "io/nrrd.h"
#include "io/synth_volumes.h"

int main(int argc, char** argv) {
  using namespace cpmesh::io;
  CLI::App app{"cpmesh-synth: synthetic labeled volumes with known interfaces, triple curves and quadruple points",
               "cpmesh-synth"};
  std::string shape, output, junctions;
  SynthOptions o;
  std::vector<double> spacing;
  bool raw = false;
  app.add_option("shape", shape, "sphere, wedge-ball, slabs, shells or head")
      ->required()
      ->check(CLI::IsMember({"sphere", "wedge-ball", "slabs", "shells", "head"}));
  app.add_option("-n,--size", o.size, "Voxels along each axis (head: along y; x and z are 199/250 and 249/250 of it)")->check(CLI::Range(4, 2048))->capture_default_str();
  app.add_option("--spacing", spacing, "Voxel spacing sx,sy,sz (physical units)")->delimiter(',')->expected(3);
  app.add_option("--radius", o.radius, "Outer radius in voxels (default: 0.35 n sphere, 50/128 n wedge ball, 0.45 n shells)")
      ->check(CLI::PositiveNumber);
  app.add_option("-o,--output", output, "Output NRRD file (gzip-compressed unless --raw-encoding)")->required();
  app.add_option("--junctions", junctions, "Also write the analytic triple curves and quadruple points as JSON");
  app.add_flag("--raw-encoding", raw, "Write uncompressed NRRD");
  CLI11_PARSE(app, argc, argv);
  try {
    o.shape = parse_synth_shape(shape);
    if (!spacing.empty()) o.spacing = {spacing[0], spacing[1], spacing[2]};
    const SynthVolume s = make_synth_volume(o);
    write_nrrd(output, s.volume, !raw);
    if (!junctions.empty()) write_junctions_json(junctions, s);
    const auto& d = s.volume.dims;
    std::cout << "wrote " << output << " (" << shape << ", " << d[0] << " x " << d[1] << " x " << d[2] << ")";
    if (!junctions.empty())
      std::cout << " and " << junctions << " (" << s.junctions.triple_curves.size() << " triple curves, "
                << s.junctions.quadruple_points.size() << " quadruple points)";
    std::cout << '\n';
  } catch (const std::exception& e) {
    std::cerr << "cpmesh-synth: error: " << e.what() << '\n';
    return 1;
  }
  return 0;
}
