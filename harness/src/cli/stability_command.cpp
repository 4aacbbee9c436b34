// `photonbench stability STABILITY_FILE`: every technique through every stress scenario, each cell
// classified ok, degraded or failed with its reason, into stability.csv (run/stability.h).
#include <filesystem>

#include "cli/command.h"
#include "run/stability.h"

namespace {

void add_stability(CLI::App& app, int& exit_code) {
  auto options = std::make_shared<pb::run::StabilityOptions>();
  auto* cmd = app.add_subcommand(
      "stability",
      "run the stress suite (configs/stress/stability.yaml) and classify every technique x "
      "scenario cell ok, degraded or failed, with the reason, into stability.csv");
  cmd->add_option("stability_file", options->stability_file,
                  "a stability file: a benchmark config's keys with `stability` and `scenarios`")
      ->required()
      ->check(CLI::ExistingFile);
  // --set overrides keys of the generated benchmark config.
  pb::cli::add_run_options(cmd, *options);
  cmd->add_option("--technique", options->techniques,
                  "run only this technique of the file's (repeatable), with the no-GI technique; "
                  "scenario parameters only the others have are dropped");
  cmd->callback([options, &exit_code] {
    if (std::getenv("PB_VALIDATION")) options->validation = true;
    exit_code = pb::run::run_stability(*options);
  });
}

pb::cli::CommandRegistration stability_registration{"stability", add_stability};

}  // namespace
