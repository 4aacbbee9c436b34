// A benchmark run: config -> cells -> one child process per cell -> summary. The run folder is the
// unit of resumption: complete cells are folders with a cell.json; anything else is redone.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "plan/plan.h"
#include "run/shard.h"

namespace pb::run {

struct RunOptions {
  std::filesystem::path config_file;
  std::vector<std::string> overrides;
  std::filesystem::path out_dir;  // empty: results/<name>-<timestamp>
  std::string device;
  bool resume = false;
  bool validation = false;
  ShardSpec shard;  // --shard I/N: only that shard's cells (run/shard.h)
};

// Returns the process exit code: 0 all cells ok, 1 some cell failed. Bad input throws
// pb::InputError.
int run_benchmark(const RunOptions& options);

// Renders every reference image the cells will be scored against that the cache lacks (run does
// this before its first cell; `photonbench reference CONFIG` does only this): each reference is
// rendered once and shared by every technique and setting of its scene.
void render_needed_references(const config::Config& config, const std::vector<Cell>& cells,
                              PluginRegistry& plugins);
// A YAML file with a `techniques` key: a benchmark config rather than a scene.
bool is_benchmark_config(const std::filesystem::path& file);

// Rebuilds summary.csv from the cells/ folder (also used after each cell, so an interrupted run has
// one). Each cell of `not_run` without a record gets a row of status not_run (an interrupted run).
void write_summary(const std::filesystem::path& run_dir, const std::vector<Cell>& not_run = {});

}  // namespace pb::run
