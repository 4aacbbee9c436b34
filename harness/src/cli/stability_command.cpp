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
  cmd->add_option("--out", options->out_dir, "run folder (default results/<name>-<time>)");
  cmd->add_option("--device", options->device,
                  "Vulkan device whose name contains this (default: lavapipe)");
  cmd->add_option("--set", options->overrides,
                  "override a key of the generated benchmark config: key.path=value (repeatable)");
  cmd->add_flag("--resume", options->resume, "continue the run in --out, skipping complete cells");
  cmd->add_flag("--validation", options->validation,
                "Vulkan validation layers on; an error fails the cell");
  cmd->callback([options, &exit_code] {
    if (std::getenv("PB_VALIDATION")) options->validation = true;
    exit_code = pb::run::run_stability(*options);
  });
}

pb::cli::CommandRegistration stability_registration{"stability", add_stability};

}  // namespace
