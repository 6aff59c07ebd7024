#pragma once
// The cpmesh subcommands. Each add_* registers its subcommand (options, --help text) on the app and returns the action
// to run when it was chosen; its option values live in the action's closure.
#include <functional>
#include <string>

#include <CLI/CLI.hpp>

#include "gpu/context.h"
#include "fields/fields_stage.h"
#include "particles/population.h"

namespace cpmesh::cli {

struct GlobalOptions {
  std::string device;
  bool profile = false;
  bool validation = false;
  gpu::ContextOptions context() const { return gpu::ContextOptions{device, validation, profile}; }
};

struct Command {
  CLI::App* sub = nullptr;
  std::function<int()> run;
};

Command add_devices_command(CLI::App& app, const GlobalOptions& g);
Command add_selftest_command(CLI::App& app, const GlobalOptions& g);
Command add_info_command(CLI::App& app, const GlobalOptions& g);
Command add_fields_command(CLI::App& app, const GlobalOptions& g);
Command add_particles_command(CLI::App& app, const GlobalOptions& g);
Command add_mesh_command(CLI::App& app, const GlobalOptions& g);

// Option groups shared by the commands that run those stages (one help text each).
void add_fields_options(CLI::App* sub, fields::FieldsOptions& f);              // fields, particles, mesh
void add_advection_options(CLI::App* sub, particles::AdvectionOptions& a);     // particles, mesh
// The population parameters (seeding, add/delete), shared by `particles` and `mesh`.
void add_population_options(CLI::App* sub, particles::PopulationOptions& p);

// Prints the per-kernel profile when --profile was given.
void print_profile(const gpu::Context& ctx, const GlobalOptions& g);

}  // namespace cpmesh::cli
