// `photonbench run CONFIG`: the benchmark. `photonbench __cell RUN_DIR CELL` is its hidden child:
// one cell in its own process.
#include <filesystem>

#include "cell/cell_runner.h"
#include "cell/invocation.h"
#include "cli/command.h"
#include "photonbench/error.h"
#include "run/runner.h"

namespace {

// `run --resume --out DIR` without a config: the config and --set values DIR's invocation.json
// records, so an interrupted run resumes without retyping them.
void use_recorded_invocation(pb::run::RunOptions& options) {
  if (!options.resume || options.out_dir.empty())
    throw pb::InputError(
        "run: a CONFIG is required (or --resume --out DIR, which reuses the config DIR records)");
  if (!options.overrides.empty())
    throw pb::InputError(
        "run --resume without a CONFIG reuses the recorded --set, --seeds and --plugin-dir "
        "values; give the config too to state them again");
  const pb::run::Invocation recorded = pb::run::read_invocation(options.out_dir);
  options.config_file = recorded.config_file;
  options.overrides = recorded.overrides;
}

void add_run(CLI::App& app, int& exit_code) {
  auto options = std::make_shared<pb::run::RunOptions>();
  auto* cmd = app.add_subcommand("run", "run a benchmark config: every cell, timed and scored");
  cmd->add_option("config", options->config_file,
                  "the YAML config (with --resume --out DIR: the one DIR records, unless given)")
      ->check(CLI::ExistingFile);
  pb::cli::add_run_options(cmd, *options);
  auto plugin_dirs = std::make_shared<std::vector<std::string>>();
  cmd->add_option("--plugin-dir", *plugin_dirs,
                  "also load technique plugins from this folder (repeatable)")
      ->check(CLI::ExistingDirectory);
  auto shard = std::make_shared<std::string>();
  cmd->add_option("--shard", *shard,
                  "I/N: run only shard I of N, a deterministic subset of the cells balanced by "
                  "their estimated cost; `merge` joins the N run folders");
  auto seeds = std::make_shared<uint32_t>(0);
  cmd->add_option("--seeds", *seeds,
                  "K: run every cell with K seeds (config seed + 0 .. K - 1); the same as --set "
                  "seeds=K")
      ->check(CLI::Range(1, 1000));
  cmd->callback([options, plugin_dirs, shard, seeds, &exit_code] {
    if (!shard->empty()) options->shard = pb::run::parse_shard(*shard);
    if (*seeds > 0) options->overrides.push_back("seeds=" + std::to_string(*seeds));
    for (const auto& dir : *plugin_dirs)
      options->overrides.push_back("plugin_dirs+=" + std::filesystem::absolute(dir).string());
    if (options->config_file.empty()) use_recorded_invocation(*options);
    if (std::getenv("PB_VALIDATION")) options->validation = true;
    exit_code = pb::run::run_benchmark(*options);
  });
}

void add_cell(CLI::App& app, int& exit_code) {
  auto options = std::make_shared<pb::run::CellRunOptions>();
  auto* cmd = app.add_subcommand("__cell", "");  // an empty description hides it from --help
  cmd->group("");
  cmd->add_option("run_dir", options->run_dir)->required();
  cmd->add_option("cell", options->cell_id)->required();
  cmd->add_option("--device", options->device);
  cmd->add_flag("--validation", options->validation);
  cmd->callback([options, &exit_code] { exit_code = pb::run::run_cell(*options); });
}

pb::cli::CommandRegistration run_registration{"run", add_run};
pb::cli::CommandRegistration cell_registration{"__cell", add_cell};

}  // namespace
