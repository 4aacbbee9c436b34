// Sub-commands. Each lives in its own file and registers itself with one static
// CommandRegistration, so adding a command touches no other file:
//
//   static void add_validate(CLI::App& app, int& exit_code) {
//     auto* cmd = app.add_subcommand(...); ...
//   }
//   static pb::cli::CommandRegistration registration{"validate", add_validate};
//
// A command sets `exit_code` (0 ok, 1 failed work, 2 bad input) or throws: main turns
// pb::InputError into exit 2 and any other exception into exit 1, printing the message.
#pragma once

#include <CLI/CLI.hpp>

namespace pb::cli {

using AddCommand = void (*)(CLI::App& app, int& exit_code);

struct CommandRegistration {
  CommandRegistration(const char* name, AddCommand add);
};

// The options of a command that runs a benchmark's cells (`run`, `stability`): where the run goes,
// on which device, which config keys are overridden, and whether it resumes or validates.
template <class RunOptions>
void add_run_options(CLI::App* cmd, RunOptions& options) {
  cmd->add_option("--out", options.out_dir, "run folder (default results/<name>-<time>)");
  cmd->add_option("--device", options.device,
                  "Vulkan device whose name contains this (default: lavapipe)");
  cmd->add_option("--set", options.overrides,
                  "override a config key: key.path=value, or key+=value to append (repeatable)");
  cmd->add_flag("--resume", options.resume, "continue the run in --out, skipping complete cells");
  cmd->add_flag("--validation", options.validation,
                "Vulkan validation layers on; an error fails the cell");
}

}  // namespace pb::cli
