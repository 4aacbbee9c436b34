#include "run/runner.h"

#include <fcntl.h>
#include <fmt/chrono.h>
#include <fmt/format.h>
#include <signal.h>
#include <sys/file.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "cell/cell_process.h"
#include "cell/cell_runner.h"
#include "cell/invocation.h"
#include "cell/scoring.h"
#include "io/results.h"
#include "photonbench/error.h"
#include "reference/reference.h"
#include "run/cell_runs.h"
#include "run/interrupt.h"
#include "run/match.h"
#include "run/run_record.h"
#include "run/seed_stats.h"
#include "scene/scene.h"

namespace pb::run {

using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

std::string fmt_or_empty(const json& value) {
  if (value.is_null() || !value.is_number()) return "";
  return fmt::format("{:.6g}", value.get<double>());
}

}  // namespace

bool is_benchmark_config(const std::filesystem::path& file) {
  if (file.extension() != ".yaml" && file.extension() != ".yml") return false;
  if (!std::filesystem::is_regular_file(file)) return false;
  try {
    YAML::Node root = YAML::LoadFile(file.string());
    return root.IsMap() && root["techniques"].IsDefined();
  } catch (const YAML::Exception&) {
    return false;
  }
}

void render_needed_references(const config::Config& config, const std::vector<Cell>& cells,
                              PluginRegistry& plugins) {
  std::vector<uint32_t> frames = metric_frames(config);
  if (frames.empty() || config.metrics.empty()) return;  // nothing to score against them
  // Classes per scene file and reference depth: the full reference and, when the config asks for
  // them, the bounce-matched ones of the cells' techniques (scored_references).
  // The options are the cells' own (a scene entry may set its stop rules; the plan checks that
  // the entries of one scene file agree).
  struct Needed {
    uint32_t mask = 0;
    trace::ReferenceOptions options;
  };
  std::map<std::pair<std::filesystem::path, uint32_t>, Needed> needed;
  for (const auto& cell : cells) {
    const Plugin* plugin = plugins.find(cell.technique);
    if (!plugin || !plugin->loaded()) continue;
    const uint32_t classes = reference_classes(plugin->descriptor->path_class);
    for (const ScoredReference& ref : scored_references(config, cell)) {
      Needed& n = needed[{cell.scene_file, ref.options.max_bounces}];
      n.mask |= classes;
      n.options = ref.options;
    }
  }
  trace::ReferenceCache cache(config.reference.cache_dir);
  for (const auto& [key, need] : needed) {
    const auto& [file, bounces] = key;
    const uint32_t mask = need.mask;
    const trace::ReferenceOptions& options = need.options;
    scene::Scene scene = scene::load_scene(file);
    const std::string label = bounces == config.reference.max_bounces
                                  ? scene.name
                                  : fmt::format("{} (max_bounces {})", scene.name, bounces);
    for (size_t i = 0; i < frames.size(); ++i) {
      auto start = Clock::now();
      auto last_print = start;
      bool tty = isatty(STDERR_FILENO);
      trace::ReferenceProgress last;
      auto report = [&](const trace::ReferenceProgress& p) {
        last = p;
        if (!tty && Clock::now() - last_print < std::chrono::seconds(10)) return;
        last_print = Clock::now();
        std::string line = trace::describe_progress(p);
        if (tty)
          std::fprintf(stderr, "\r\033[K[reference] %s frame %u: %s", label.c_str(), frames[i],
                       line.c_str());
        else
          std::fprintf(stderr, "[reference] %s frame %u: %s\n", label.c_str(), frames[i],
                       line.c_str());
        std::fflush(stderr);
      };
      int rendered = cache.render_missing(scene, scene.at(frames[i]), mask, int(config.width),
                                          int(config.height), options, report);
      if (tty) std::fprintf(stderr, "\r\033[K");
      double seconds = std::chrono::duration<double>(Clock::now() - start).count();
      std::string what = rendered ? fmt::format("rendered in {:.1f} s ({})", seconds,
                                                trace::describe_progress(last))
                                  : std::string("cached");
      std::fprintf(stderr, "[reference] %s frame %u (%zu/%zu): %s\n", label.c_str(), frames[i],
                   i + 1, frames.size(), what.c_str());
    }
  }
}

void write_summary(const std::filesystem::path& run_dir, const std::vector<Cell>& not_run) {
  std::vector<json> records;
  std::set<std::string> params, passes;
  std::set<std::string> recorded;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(run_dir / "cells", ec)) {
    auto file = entry.path() / "cell.json";
    if (entry.path().filename().string().rfind(".partial-", 0) == 0 ||
        !std::filesystem::exists(file))
      continue;
    records.push_back(json::parse(io::read_text(file)));
    recorded.insert(records.back().value("cell", ""));
    for (const auto& [k, v] : records.back()["params"].items()) params.insert(k);
    if (records.back().contains("summary"))
      for (const auto& [k, v] : records.back()["summary"]["pass_ms_median"].items())
        passes.insert(k);
  }
  // An interrupted run's cells that have no record: a row each, so that the summary does not read
  // as a complete run of fewer cells.
  for (const Cell& cell : not_run) {
    if (recorded.count(cell.id)) continue;
    records.push_back({{"cell", cell.id},
                       {"scene", cell.scene},
                       {"technique", cell.technique},
                       {"status", "not_run"},
                       {"params", cell.params},
                       {"reason", "not run: the run was interrupted (run.json: interrupted)"}});
    if (cell.seed_index > 0) records.back()["seed"] = cell.seed;
    for (const auto& [k, v] : cell.params) params.insert(k);
  }
  std::sort(records.begin(), records.end(),
            [](const json& a, const json& b) { return a["cell"] < b["cell"]; });
  std::vector<std::string> header = {"cell",       "scene",       "technique",
                                     "status",     "frames",      "wall_ms_median",
                                     "wall_ms_p5", "wall_ms_p95", "flip_mean",
                                     "ssim_mean",  "psnr_mean",   "flip_floor",
                                     "ssim_floor", "psnr_floor",  "harness_overhead_pct",
                                     "seed"};
  for (const auto& p : params) header.push_back("param." + p);
  for (const auto& p : passes) header.push_back("pass." + p + ".ms_median");
  header.push_back("reason");
  std::string text = io::csv_row(header);
  for (const json& r : records) {
    json summary = r.value("summary", json::object());
    json frame = summary.value("frame_ms", json::object());
    json combined = r.value("metrics", json::object()).value("combined", json::object());
    std::vector<std::string> row = {r["cell"],
                                    r["scene"],
                                    r["technique"],
                                    r["status"],
                                    std::to_string(r.value("frames_measured", 0)),
                                    fmt_or_empty(frame.value("median", json())),
                                    fmt_or_empty(frame.value("p5", json())),
                                    fmt_or_empty(frame.value("p95", json())),
                                    fmt_or_empty(combined.value("flip", json())),
                                    fmt_or_empty(combined.value("ssim", json())),
                                    fmt_or_empty(combined.value("psnr", json())),
                                    fmt_or_empty(combined.value("flip_floor", json())),
                                    fmt_or_empty(combined.value("ssim_floor", json())),
                                    fmt_or_empty(combined.value("psnr_floor", json())),
                                    fmt_or_empty(summary.value("harness_overhead_pct", json())),
                                    r.contains("seed") ? r["seed"].dump() : ""};
    for (const auto& p : params) row.push_back(r["params"].value(p, ""));
    for (const auto& p : passes)
      row.push_back(fmt_or_empty(summary.value("pass_ms_median", json::object()).value(p, json())));
    row.push_back(r.value("reason", ""));
    text += io::csv_row(row);
  }
  io::write_text_atomic(run_dir / "summary.csv", text);
}

namespace {

// Held for the life of a run: a second `run` or `--resume` into the same folder while this one
// runs is refused, instead of both recording every cell failed. flock(2) locks go with the
// process however it ends, so a killed run leaves no stale lock; O_CLOEXEC keeps the cells' child
// processes from holding it.
class RunDirLock {
 public:
  explicit RunDirLock(const std::filesystem::path& run_dir) {
    const std::filesystem::path file = run_dir / ".lock";
    file_ = file;
    fd_ = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0)
      throw InputError(fmt::format("--out {}: cannot create {}: {}", run_dir.string(),
                                   file.filename().string(), std::strerror(errno)));
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      // The holder writes its pid just after it takes the lock: a run refused in between reads
      // an empty file, so it looks again for up to 50 ms before it names no pid.
      char holder[32] = {};
      ssize_t n = ::pread(fd_, holder, sizeof(holder) - 1, 0);
      for (int retry = 0; n <= 0 && retry < 10; ++retry) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        n = ::pread(fd_, holder, sizeof(holder) - 1, 0);
      }
      ::close(fd_);
      throw InputError(fmt::format(
          "{} is in use by another photonbench run{}; wait for it to end, or use another --out",
          run_dir.string(), n > 0 ? fmt::format(" (pid {})", std::string(holder, size_t(n))) : ""));
    }
    // The pid only improves the message above; failing to write it changes nothing.
    const std::string pid = std::to_string(::getpid());
    if (::ftruncate(fd_, 0) == 0) (void)!::pwrite(fd_, pid.data(), pid.size(), 0);
  }
  // The file goes with the lock, so a finished or interrupted run leaves none behind (a run that
  // is killed outright leaves the file, but no lock on it).
  ~RunDirLock() {
    ::unlink(file_.c_str());
    ::close(fd_);
  }
  RunDirLock(const RunDirLock&) = delete;
  RunDirLock& operator=(const RunDirLock&) = delete;

 private:
  int fd_ = -1;
  std::filesystem::path file_;
};

struct RunDir {
  std::filesystem::path path;
  std::unique_ptr<RunDirLock> lock;
};

// The run folder: a new one (results/<name>-<time> unless --out names it), or with --resume the
// folder of an interrupted run of the same config, locked for this run. The invocation is written
// into it, for each cell's child process and for a later --resume.
RunDir open_run_dir(const RunOptions& options, const config::Config& config) {
  namespace fs = std::filesystem;
  fs::path run_dir = options.out_dir;
  if (options.resume && run_dir.empty())
    throw InputError("--resume needs --out DIR, the run folder to continue");
  if (run_dir.empty()) {
    auto now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
    run_dir =
        fs::path("results") / fmt::format("{}-{:%Y%m%d-%H%M%S}", config.name, fmt::localtime(now));
  }
  std::error_code ec;
  if (fs::exists(run_dir, ec) && !fs::is_directory(run_dir, ec))
    throw InputError(fmt::format("--out {}: exists and is not a folder", run_dir.string()));
  if (options.resume && !fs::exists(run_dir / "invocation.json", ec))
    throw InputError(
        fmt::format("--resume: {} is not a photonbench run folder (no "
                    "invocation.json); run without --resume to start one",
                    run_dir.string()));
  fs::create_directories(run_dir / "cells", ec);
  if (ec)
    throw InputError(
        fmt::format("--out {}: cannot create the run folder: {}", run_dir.string(), ec.message()));
  run_dir = fs::canonical(run_dir, ec);
  if (ec) throw InputError(fmt::format("--out {}: {}", options.out_dir.string(), ec.message()));
  RunDir result{run_dir, std::make_unique<RunDirLock>(run_dir)};
  if (options.resume) {
    Invocation previous;
    try {
      previous = read_invocation(run_dir);
    } catch (const nlohmann::json::exception& e) {
      throw InputError(
          fmt::format("--resume: {}/invocation.json is damaged: {}", run_dir.string(), e.what()));
    }
    if (previous.config_hash != config.hash)
      throw InputError(
          fmt::format("--resume: {} was run with a different config (hash {}, now {}); "
                      "resume with the same config and --set values",
                      run_dir.string(), previous.config_hash, config.hash));
  } else if (fs::exists(run_dir / "run.json", ec) || fs::exists(run_dir / "invocation.json", ec)) {
    throw InputError(fmt::format(
        "{} already holds a run; use --resume to continue it, or another --out", run_dir.string()));
  }
  try {
    write_invocation(run_dir, {fs::absolute(options.config_file), options.overrides, config.hash});
  } catch (const std::exception& e) {
    throw InputError(
        fmt::format("--out {}: cannot write to the run folder: {}", run_dir.string(), e.what()));
  }
  return result;
}

// Every cell in its own child process, in order; with --resume a cell whose folder is complete is
// skipped. summary.csv is rewritten after each cell, so an interrupted run has one.
CellTally run_cells(const RunPlan& plan, const RunOptions& options,
                    const std::filesystem::path& run_dir) {
  CellRuns runs(run_dir, {options.device, options.validation, plan.config.limits.cell_seconds},
                options.resume, plan.cells.size(), [&] { write_summary(run_dir); });
  for (const Cell& cell : plan.cells) runs.run(cell);
  return runs.tally();
}

// A run a signal stopped (run/interrupt.h): the summary lists the plan's cells not run, run.json
// says so, and the resume command is printed. Returns the exit code a shell gives a process the
// signal ended (128 + signal).
int stop_interrupted(const RunPlan& plan, const std::filesystem::path& run_dir, json& run,
                     int signal, const std::string& resume) {
  write_summary(run_dir, plan.config.match ? std::vector<Cell>{} : plan.cells);
  run["interrupted"] = {{"signal", signal == SIGTERM ? "SIGTERM" : "SIGINT"}, {"at", now_iso()}};
  io::write_text_atomic(run_dir / "run.json", run.dump(2) + "\n");
  size_t complete = 0;
  for (const Cell& cell : plan.cells)
    complete += std::filesystem::exists(cell_dir(run_dir, cell.id) / "cell.json");
  std::fprintf(
      stderr,
      "photonbench: interrupted (%s): %zu of %zu cells have records; summary.csv lists the "
      "rest as not_run. Resume with:\n  %s\n",
      signal == SIGTERM ? "SIGTERM" : "SIGINT", complete, plan.cells.size(), resume.c_str());
  return 128 + signal;
}

}  // namespace

int run_benchmark(const RunOptions& options) {
  RunPlan plan = plan_run(options.config_file, options.overrides);
  for (const std::string& warning : plan.warnings)
    std::fprintf(stderr, "photonbench: warning: %s\n", warning.c_str());
  const MatchPlan matches = plan_matches(plan);  // bad match input: before any work
  if (plan.config.match && options.shard.sharded())
    plan.config.match->node.fail(
        "a match run cannot be sharded (--shard): each probe's knob value comes from the probes "
        "before it; run it whole, or split it into one config per scene");
  // A shard runs its own cells only; each cell's child rebuilds the whole plan and finds its cell.
  const ShardSelection shard = select_shard(plan, options.shard);
  plan.cells = shard.cells;
  const RunDir opened = open_run_dir(options, plan.config);
  const std::filesystem::path& run_dir = opened.path;
  const std::string resume =
      resume_command(run_dir, options.device, options.validation,
                     options.shard.sharded() ? options.shard.text() : std::string());
  InterruptGuard interrupts(run_dir / ".lock", resume);
  if (options.resume) check_resumed_shard(run_dir, options.shard);
  json run = describe_run(options.config_file, options.overrides, options.device, plan, run_dir);
  if (options.shard.sharded()) run["shard"] = describe_shard(options.shard, shard);
  io::write_text_atomic(run_dir / "run.json", run.dump(2) + "\n");
  if (options.shard.sharded())
    std::fprintf(stderr,
                 "photonbench: shard %s, %zu of %zu cells (%.1f%% of the estimated work) -> %s\n",
                 options.shard.text().c_str(), plan.cells.size(), shard.every.size(),
                 100 * shard.share(), run_dir.string().c_str());
  else if (plan.config.match)
    std::fprintf(stderr,
                 "photonbench: %zu matches and %zu baseline cells (at most %zu cells) -> %s\n",
                 matches.matches.size(), matches.unmatched.size(),
                 match_cell_bound(plan.config, matches), run_dir.string().c_str());
  else
    std::fprintf(stderr, "photonbench: %zu cells -> %s\n", plan.cells.size(),
                 run_dir.string().c_str());

  render_needed_references(plan.config, plan.cells, *plan.plugins);
  // A match run starts the cells its searches ask for (run/match.h); a plain run every cell.
  int unmatched = 0;
  CellTally tally;
  interrupts.stop_cleanly_from_now();
  try {
    if (plan.config.match) {
      CellRuns runs(run_dir, {options.device, options.validation, plan.config.limits.cell_seconds},
                    options.resume, match_cell_bound(plan.config, matches),
                    [&] { write_summary(run_dir); });
      const MatchOutcome outcome = run_matches(plan, matches, runs);
      tally = outcome.tally;
      unmatched = outcome.unmatched;
    } else {
      tally = run_cells(plan, options, run_dir);
    }
  } catch (const Interrupted& stop) {
    return stop_interrupted(plan, run_dir, run, stop.signal, resume);
  }

  write_summary(run_dir);
  // A shard holds only some of a seed group's cells; a merged run is summarised by the tools' own
  // seed spread (tools/pbtools/seeds.py), without the per-pixel images. A match run's seed cells
  // are its found cells' (match.csv gives their spread), not the plan's.
  if (!options.shard.sharded() && plan.config.seeds > 1 && !plan.config.match) {
    std::fprintf(stderr, "photonbench: seed statistics of %zu cells -> %s\n", plan.cells.size(),
                 (run_dir / "seeds").string().c_str());
    write_seed_statistics(plan, run_dir);
  }
  run["end"] = now_iso();
  io::write_text_atomic(run_dir / "run.json", run.dump(2) + "\n");
  std::fprintf(stderr, "photonbench: %zu cells, %d failed%s. Summary: %s\n",
               plan.config.match ? size_t(tally.run) : plan.cells.size(), tally.failed,
               tally.skipped ? fmt::format(", {} already complete", tally.skipped).c_str() : "",
               (run_dir / "summary.csv").string().c_str());
  if (plan.config.match)
    std::fprintf(stderr, "photonbench: %zu matches, %d not matched. Matches: %s\n",
                 matches.matches.size(), unmatched, (run_dir / "match.csv").string().c_str());
  return tally.failed || unmatched ? 1 : 0;
}

}  // namespace pb::run
