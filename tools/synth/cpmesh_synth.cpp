// cpmesh-synth: writes a synthetic labeled volume with known answers (docs/design.md) or a volume of the realistic
// corpus (engine/io/synth_corpus.h) and, for the wedge ball, its analytic triple curves and quadruple points as JSON.
#include <iostream>

#include <CLI/CLI.hpp>

#include "io/nrrd.h"
#include "io/synth_corpus.h"
#include "io/synth_volumes.h"

int main(int argc, char** argv) {
  using namespace cpmesh::io;
  CLI::App app{"cpmesh-synth: synthetic labeled volumes, analytic (known interfaces, triple curves and quadruple points) "
               "or realistic (the corpus: parcellations, thin sheets and tubes, islands, organs)",
               "cpmesh-synth"};
  std::string shape, output, junctions, named;
  SynthOptions o;
  std::vector<double> spacing;
  bool raw = false, list = false;
  app.add_option("shape", shape, "sphere, wedge-ball, slabs, shells, head, parcellation, thin, islands or organs")
      ->check(CLI::IsMember({"sphere", "wedge-ball", "slabs", "shells", "head", "parcellation", "thin", "islands", "organs"}));
  app.add_option("--corpus", named, "A named volume of the realistic corpus (--list shows them) instead of a shape");
  app.add_flag("--list", list, "List the corpus's volumes with their options and exit");
  app.add_option("-n,--size", o.size, "Voxels along each axis (head: along y, x and z 199/250 and 249/250 of it; organs: "
                                      "along x, y and z 0.806 and 0.377 of it)")
      ->check(CLI::Range(4, 2048))
      ->capture_default_str();
  app.add_option("--spacing", spacing, "Voxel spacing sx,sy,sz (physical units)")->delimiter(',')->expected(3);
  app.add_option("--radius", o.radius, "Outer radius in voxels (default: 0.35 n sphere, 50/128 n wedge ball, 0.45 n shells)")
      ->check(CLI::PositiveNumber);
  app.add_option("--labels", o.labels, "Parcels of a parcellation (default 80)")->check(CLI::Range(2, 1000));
  app.add_option("--noise", o.noise, "Corpus kinds: share of label-boundary voxels flipped to a neighbour's label")
      ->check(CLI::Range(0.0, 0.5));
  app.add_option("--seed", o.seed, "Corpus kinds: the random layout")->capture_default_str();
  app.add_option("-o,--output", output, "Output NRRD file (gzip-compressed unless --raw-encoding)");
  app.add_option("--junctions", junctions, "Also write the analytic triple curves and quadruple points as JSON");
  app.add_flag("--raw-encoding", raw, "Write uncompressed NRRD");
  CLI11_PARSE(app, argc, argv);
  try {
    if (list) {
      for (const auto& e : corpus()) {
        const auto& c = e.options;
        std::cout << e.name << ": " << synth_shape_name(c.shape) << " -n " << c.size;
        if (c.labels) std::cout << " --labels " << c.labels;
        if (c.noise > 0) std::cout << " --noise " << c.noise;
        if (c.spacing != std::array<double, 3>{1, 1, 1})
          std::cout << " --spacing " << c.spacing[0] << ',' << c.spacing[1] << ',' << c.spacing[2];
        std::cout << (e.large ? "  (benchmark size)" : "") << '\n';
      }
      return 0;
    }
    if (named.empty() == shape.empty()) throw std::invalid_argument("give a shape or --corpus NAME (not both)");
    if (output.empty()) throw std::invalid_argument("option '--output': expected the NRRD file to write");
    if (!named.empty()) o = corpus_entry(named).options;
    else o.shape = parse_synth_shape(shape);
    if (!spacing.empty()) o.spacing = {spacing[0], spacing[1], spacing[2]};
    const SynthVolume s = make_synth_volume(o);
    write_nrrd(output, s.volume, !raw);
    if (!junctions.empty()) write_junctions_json(junctions, s);
    const auto& d = s.volume.dims;
    std::cout << "wrote " << output << " (" << synth_shape_name(o.shape) << ", " << d[0] << " x " << d[1] << " x " << d[2] << ")";
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
