// One cell, run in its own child process (`photonbench __cell`): scene -> world -> technique plugin
// -> warm-up and measured frames -> results in a partial folder that is renamed into place when
// complete. Isolation means a technique that crashes, hangs or leaks takes down only its own cell.
#pragma once

#include <filesystem>
#include <string>

namespace pb::run {

struct CellRunOptions {
  std::filesystem::path run_dir;
  std::string cell_id;
  std::string device;       // --device filter
  bool validation = false;  // Vulkan validation layers; any validation error fails the cell
};

// Folder names inside a run: cells/<id>/ when complete, cells/.partial-<id>/ while running.
std::filesystem::path cell_dir(const std::filesystem::path& run_dir, const std::string& id);
std::filesystem::path partial_cell_dir(const std::filesystem::path& run_dir, const std::string& id);

// Runs the cell and writes its folder. Returns 0 when the cell's result was written (ok or failed).
// Progress goes to stdout as lines "@frame <done> <total>" for the parent.
int run_cell(const CellRunOptions& options);

}  // namespace pb::run
