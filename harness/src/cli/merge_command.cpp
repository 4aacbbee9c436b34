// `photonbench merge OUT RUN_DIR...`: joins the run folders of `run --shard I/N` into one
// (run/merge.h).
#include <filesystem>
#include <vector>

#include "cli/command.h"
#include "run/merge.h"

namespace {

void add_merge(CLI::App& app, int& exit_code) {
  auto out = std::make_shared<std::filesystem::path>();
  auto shards = std::make_shared<std::vector<std::filesystem::path>>();
  auto* cmd = app.add_subcommand(
      "merge", "join the run folders of a sharded run (run --shard I/N) into one run folder");
  cmd->add_option("out", *out, "the merged run folder (new)")->required();
  cmd->add_option("run_dirs", *shards, "the shards' run folders, one per shard")->required();
  cmd->callback([out, shards, &exit_code] { exit_code = pb::run::merge_runs(*out, *shards); });
}

pb::cli::CommandRegistration merge_registration{"merge", add_merge};

}  // namespace
