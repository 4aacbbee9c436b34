// A benchmark run: config -> cells -> one child process per cell -> summary. The run folder is the
// unit of resumption: complete cells are folders with a cell.json; anything else is redone.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace pb::run {

struct RunOptions {
  std::filesystem::path config_file;
  std::vector<std::string> overrides;
  std::filesystem::path out_dir;  // empty: results/<name>-<timestamp>
  std::string device;
  bool resume = false;
  bool validation = false;
};

// Returns the process exit code: 0 all cells ok, 1 some cell failed. Bad input throws pb::InputError.
int run_benchmark(const RunOptions& options);

// Rebuilds summary.csv from the cells/ folder (also used after each cell, so an interrupted run has one).
void write_summary(const std::filesystem::path& run_dir);

}  // namespace pb::run
