// The cells of a run, each in its own child process (cell/cell_process.h): what the plain run's
// loop (runner.cpp) and a match run's search (match.h) both start cells with. With --resume a cell
// whose record is complete and ok is kept, and one that failed is set aside and run again.
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>

#include "cell/cell_process.h"

namespace pb::run {

struct CellTally {
  int run = 0, failed = 0, skipped = 0;  // run: every cell started or kept
};

class CellRuns {
 public:
  // `cells`: how many the run starts, at most (the progress lines' count); `after_each` is called
  // after every cell (the runner rewrites summary.csv there, so an interrupted run has one).
  CellRuns(std::filesystem::path run_dir, CellProcessOptions process, bool resume, size_t cells,
           std::function<void()> after_each);
  // Runs `cell` (or keeps its complete ok record on --resume) and returns its cell.json.
  nlohmann::json run(const Cell& cell);
  const CellTally& tally() const { return tally_; }
  const std::filesystem::path& run_dir() const { return run_dir_; }

 private:
  std::filesystem::path run_dir_;
  CellProcessOptions process_;
  bool resume_;
  Progress progress_;
  std::function<void()> after_each_;
  size_t started_ = 0;
  CellTally tally_;
};

}  // namespace pb::run
