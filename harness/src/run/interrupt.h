// Ctrl-C (SIGINT) and SIGTERM during `photonbench run`. While the cells run, the first signal stops
// the run cleanly: the running cell's child is killed and its partial folder removed, no further
// cell starts, summary.csv lists the cells not run as such, run.json says the run was interrupted,
// the run folder's lock is removed, and the exact command that resumes it is printed. Before the
// cells (plan, references) nothing is half written that a clean stop would save: the signal prints
// the resume command, removes the lock and ends the process as the signal would.
#pragma once

#include <filesystem>
#include <string>

namespace pb::run {

// Thrown where a run stops for a signal (CellRuns, before a cell starts or after its child ends).
struct Interrupted {
  int signal;
};

// Installs the handlers for its lifetime (the previous ones come back after it).
class InterruptGuard {
 public:
  // `lock_file`: removed when a signal ends the process before the cells; `resume_command`: printed
  // then.
  InterruptGuard(const std::filesystem::path& lock_file, const std::string& resume_command);
  ~InterruptGuard();
  InterruptGuard(const InterruptGuard&) = delete;
  InterruptGuard& operator=(const InterruptGuard&) = delete;
  // From here on a signal stops the run cleanly (Interrupted) instead of ending the process.
  void stop_cleanly_from_now();
};

// The signal that arrived (SIGINT or SIGTERM), 0 when none did.
int interrupt_signal();
// True once a signal arrived: CellProcessOptions::stop.
bool interrupted();

// `photonbench run --resume --out DIR`, with the options invocation.json does not record
// (--device, --validation, --shard), this executable's path first.
std::string resume_command(const std::filesystem::path& run_dir, const std::string& device,
                           bool validation, const std::string& shard);

}  // namespace pb::run
