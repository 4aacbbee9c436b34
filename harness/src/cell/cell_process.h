// Each cell runs in its own child process, `photonbench __cell RUN_DIR CELL` (cell_runner.h), so a
// technique that crashes, hangs or leaks takes down only its own cell. The parent forwards the
// child's progress, kills it past the cell time limit and, for a child that ended without writing
// its cell.json, writes one saying why.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

#include "plan/plan.h"

namespace pb::run {

// Progress on stderr: a bar redrawn in place on a terminal; otherwise a line every 10 s and at each
// cell's end.
class Progress {
 public:
  explicit Progress(size_t cells);
  void update(size_t cell, const std::string& id, uint32_t done, uint32_t total, double elapsed_s);
  void finish(size_t cell, const std::string& id, const std::string& outcome);

 private:
  size_t cells_;
  bool tty_;
  std::chrono::steady_clock::time_point last_line_;
};

struct CellProcessOptions {
  std::string device;        // --device
  bool validation = false;   // --validation
  double limit_s = 0;        // limits.cell_seconds
  bool (*stop)() = nullptr;  // true: kill the child now (the run was interrupted: run/interrupt.h)
};

struct ChildOutcome {
  int exit_status = 0;  // from waitpid
  bool timed_out = false;
  uint32_t frames_done = 0;
  std::string stage;     // "scoring" or "teardown" once the frames are done ("@stage NAME")
  bool stopped = false;  // killed because options.stop said so
};

// Runs the cell's child process to its end (or kills it at the limit); its stderr goes to
// RUN_DIR/logs/<cell>.log. `index` is the cell's place in the run, for the progress lines.
ChildOutcome run_cell_process(const std::filesystem::path& run_dir, const Cell& cell,
                              const CellProcessOptions& options, Progress& progress, size_t index);

// True when the child wrote its cell.json and exited normally.
bool wrote_record(const std::filesystem::path& run_dir, const Cell& cell,
                  const ChildOutcome& outcome);

// A child that ended without writing its cell.json: records why (crash signal, exit status or time
// limit, and the frame), with the end of its log, keeping what it measured so far in the folder.
void record_abnormal_end(const std::filesystem::path& run_dir, const Cell& cell,
                         const ChildOutcome& outcome, double limit_s);

}  // namespace pb::run
