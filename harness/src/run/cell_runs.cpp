#include "run/cell_runs.h"

#include <fmt/format.h>

#include "cell/cell_runner.h"
#include "io/results.h"

namespace pb::run {

using json = nlohmann::json;

namespace {

// With --resume, a cell that failed is run again: its folder and log move to
// failed-attempts/<cell>/ (replacing an older attempt's), so the failure stays readable.
void set_failed_attempt_aside(const std::filesystem::path& run_dir, const Cell& cell) {
  namespace fs = std::filesystem;
  const fs::path aside = run_dir / "failed-attempts" / cell.id;
  fs::remove_all(aside);
  fs::create_directories(aside.parent_path());
  fs::rename(cell_dir(run_dir, cell.id), aside);
  const fs::path log = run_dir / "logs" / (cell.id + ".log");
  std::error_code ec;
  if (fs::exists(log, ec)) fs::rename(log, aside / "cell.log", ec);
}

}  // namespace

CellRuns::CellRuns(std::filesystem::path run_dir, CellProcessOptions process, bool resume,
                   size_t cells, std::function<void()> after_each)
    : run_dir_(std::move(run_dir)),
      process_(process),
      resume_(resume),
      progress_(cells),
      after_each_(std::move(after_each)) {}

json CellRuns::run(const Cell& cell) {
  const size_t i = started_++;
  ++tally_.run;
  const std::filesystem::path done = cell_dir(run_dir_, cell.id) / "cell.json";
  if (resume_ && std::filesystem::exists(done)) {
    json previous = json::parse(io::read_text(done), nullptr, false);
    if (!previous.is_discarded() && previous.value("status", "") == "ok") {
      ++tally_.skipped;
      progress_.finish(i, cell.id, "complete already, skipped");
      if (after_each_) after_each_();
      return previous;
    }
    set_failed_attempt_aside(run_dir_, cell);
  }
  const ChildOutcome outcome = run_cell_process(run_dir_, cell, process_, progress_, i);
  if (!wrote_record(run_dir_, cell, outcome))
    record_abnormal_end(run_dir_, cell, outcome, process_.limit_s);
  json record = json::parse(io::read_text(done));
  const bool ok = record["status"] == "ok";
  tally_.failed += !ok;
  progress_.finish(i, cell.id,
                   ok ? fmt::format("ok, frame median {:.2f} ms",
                                    record["summary"]["frame_ms"].value("median", 0.0))
                      : "FAILED: " + record.value("reason", std::string("?")));
  if (after_each_) after_each_();
  return record;
}

}  // namespace pb::run
