#include "run/cell_runs.h"

#include <fmt/format.h>

#include <string>
#include <vector>

#include "cell/cell_runner.h"
#include "io/results.h"
#include "run/interrupt.h"

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

// A failed cell's console line: its reason, then for a child that ended without its record (a
// crash, a kill) where its log is and the log's last lines, which hold the assertion or the
// technique's last words.
std::string failure_text(const std::filesystem::path& run_dir, const Cell& cell,
                         const json& record) {
  std::string text = "FAILED: " + record.value("reason", std::string("?"));
  const std::string tail = record.value("log_tail", std::string());
  if (tail.empty()) return text;
  std::vector<std::string> lines;
  for (size_t start = 0; start < tail.size();) {
    size_t end = tail.find('\n', start);
    if (end == std::string::npos) end = tail.size();
    if (end > start) lines.push_back(tail.substr(start, end - start));
    start = end + 1;
  }
  constexpr size_t kLogLinesShown = 4;
  const size_t first = lines.size() > kLogLinesShown ? lines.size() - kLogLinesShown : 0;
  text += fmt::format("\n    {} ends:", (run_dir / "logs" / (cell.id + ".log")).string());
  for (size_t i = first; i < lines.size(); ++i) text += "\n    | " + lines[i];
  return text;
}

}  // namespace

CellRuns::CellRuns(std::filesystem::path run_dir, CellProcessOptions process, bool resume,
                   size_t cells, std::function<void()> after_each)
    : run_dir_(std::move(run_dir)),
      process_(process),
      resume_(resume),
      progress_(cells),
      after_each_(std::move(after_each)) {
  process_.stop = &interrupted;
}

json CellRuns::run(const Cell& cell) {
  if (interrupted()) throw Interrupted{interrupt_signal()};
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
  if (interrupted() && !wrote_record(run_dir_, cell, outcome)) {
    // Not a failure of the cell: a --resume runs it again from the start.
    std::filesystem::remove_all(partial_cell_dir(run_dir_, cell.id));
    progress_.finish(i, cell.id, "stopped (interrupted)");
    throw Interrupted{interrupt_signal()};
  }
  if (!wrote_record(run_dir_, cell, outcome))
    record_abnormal_end(run_dir_, cell, outcome, process_.limit_s);
  json record = json::parse(io::read_text(done));
  const bool ok = record["status"] == "ok";
  tally_.failed += !ok;
  progress_.finish(i, cell.id,
                   ok ? fmt::format("ok, wall-clock frame median {:.2f} ms",
                                    record["summary"]["frame_ms"].value("median", 0.0))
                      : failure_text(run_dir_, cell, record));
  if (after_each_) after_each_();
  return record;
}

}  // namespace pb::run
