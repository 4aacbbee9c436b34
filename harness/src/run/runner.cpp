#include "run/runner.h"

#include <fcntl.h>
#include <fmt/chrono.h>
#include <fmt/format.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "config/config.h"
#include "io/results.h"
#include "photonbench/error.h"
#include "photonbench/gpu.h"
#include "run/cell_runner.h"
#include "run/invocation.h"
#include "run/plugins.h"
#include "run/scoring.h"
#include "scene/scene.h"
#include "trace/reference.h"
#include <yaml-cpp/yaml.h>

namespace pb::run {

using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

std::string now_iso() {
  auto now = std::chrono::system_clock::now();
  return fmt::format("{:%Y-%m-%dT%H:%M:%S}Z", fmt::gmtime(std::chrono::system_clock::to_time_t(now)));
}

std::string command_output(const std::string& command) {
  std::string out;
  if (FILE* pipe = popen(command.c_str(), "r")) {
    char buffer[256];
    while (fgets(buffer, sizeof buffer, pipe)) out += buffer;
    pclose(pipe);
  }
  while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
  return out;
}

std::string cpu_model() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);)
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown";
}

// Progress: a bar redrawn in place on a terminal; otherwise a line every 10 s and at each cell's end.
class Progress {
 public:
  Progress(size_t cells) : cells_(cells), tty_(isatty(STDERR_FILENO)) {}
  void update(size_t cell, const std::string& id, uint32_t done, uint32_t total, double elapsed_s) {
    if (tty_) {
      int width = 24, filled = total ? int(width * done / total) : 0;
      std::fprintf(stderr, "\r[cell %zu/%zu] %-44.44s [%s%s] frame %u/%u %5.0fs", cell + 1, cells_, id.c_str(),
                   std::string(filled, '#').c_str(), std::string(width - filled, '.').c_str(), done, total, elapsed_s);
      std::fflush(stderr);
    } else if (Clock::now() - last_line_ > std::chrono::seconds(10)) {
      std::fprintf(stderr, "[cell %zu/%zu] %s: frame %u/%u, %.0f s\n", cell + 1, cells_, id.c_str(), done, total,
                   elapsed_s);
      last_line_ = Clock::now();
    }
  }
  void finish(size_t cell, const std::string& id, const std::string& outcome) {
    if (tty_) std::fprintf(stderr, "\r\033[K");
    std::fprintf(stderr, "[cell %zu/%zu] %s: %s\n", cell + 1, cells_, id.c_str(), outcome.c_str());
    last_line_ = Clock::now();
  }

 private:
  size_t cells_;
  bool tty_;
  Clock::time_point last_line_ = Clock::now();
};

struct ChildOutcome {
  int exit_status = 0;  // from waitpid
  bool timed_out = false;
  uint32_t frames_done = 0;
};

// Runs `photonbench __cell` for one cell, forwarding its progress; kills it past the time limit.
ChildOutcome run_child(const std::filesystem::path& run_dir, const config::Cell& cell, const RunOptions& options,
                       double limit_s, Progress& progress, size_t index) {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) throw Error(fmt::format("pipe failed: {}", std::strerror(errno)));
  std::filesystem::create_directories(run_dir / "logs");
  std::string log = (run_dir / "logs" / (cell.id + ".log")).string();
  std::vector<std::string> args = {"photonbench", "__cell", run_dir.string(), cell.id};
  if (!options.device.empty()) args.insert(args.end(), {"--device", options.device});
  if (options.validation) args.push_back("--validation");

  pid_t pid = fork();
  if (pid < 0) throw Error(fmt::format("fork failed: {}", std::strerror(errno)));
  if (pid == 0) {
    // The cell dies with the run: a killed `photonbench run` leaves no orphaned cell behind.
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    dup2(pipe_fds[1], STDOUT_FILENO);
    int log_fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (log_fd >= 0) dup2(log_fd, STDERR_FILENO);
    close(pipe_fds[0]);
    close(pipe_fds[1]);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv("/proc/self/exe", argv.data());
    _exit(127);
  }
  close(pipe_fds[1]);
  ChildOutcome outcome;
  auto start = Clock::now();
  std::string buffer;
  bool open_pipe = true;
  while (open_pipe) {
    pollfd fd{pipe_fds[0], POLLIN, 0};
    int ready = poll(&fd, 1, 200);
    double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    if (ready > 0) {
      char chunk[4096];
      ssize_t n = read(pipe_fds[0], chunk, sizeof chunk);
      if (n <= 0) {
        open_pipe = false;
      } else {
        buffer.append(chunk, size_t(n));
        for (size_t eol; (eol = buffer.find('\n')) != std::string::npos; buffer.erase(0, eol + 1)) {
          uint32_t done = 0, total = 0;
          if (std::sscanf(buffer.c_str(), "@frame %u %u", &done, &total) == 2) {
            outcome.frames_done = done;
            progress.update(index, cell.id, done, total, elapsed);
          }
        }
      }
    }
    if (elapsed > limit_s) {
      kill(pid, SIGKILL);
      outcome.timed_out = true;
      break;
    }
  }
  close(pipe_fds[0]);
  waitpid(pid, &outcome.exit_status, 0);
  return outcome;
}

// A child that ended without writing its cell.json: record why, keeping what it measured so far.
void record_abnormal_end(const std::filesystem::path& run_dir, const config::Cell& cell, const ChildOutcome& outcome,
                         double limit_s) {
  std::filesystem::path partial = partial_cell_dir(run_dir, cell.id), dir = cell_dir(run_dir, cell.id);
  std::filesystem::remove_all(dir);
  if (std::filesystem::exists(partial)) std::filesystem::rename(partial, dir);
  else std::filesystem::create_directories(dir);
  // frames_done counts frames finished; the one that failed is the next (index frames_done), or set-up.
  json failed_frame = outcome.frames_done > 0 || outcome.timed_out ? json(outcome.frames_done) : json(nullptr);
  std::string where = failed_frame.is_null() ? "during set-up" : fmt::format("at frame {}", outcome.frames_done);
  std::string reason;
  if (outcome.timed_out) {
    reason = fmt::format("exceeded limits.cell_seconds = {} s {}", limit_s, where);
  } else if (WIFSIGNALED(outcome.exit_status)) {
    int sig = WTERMSIG(outcome.exit_status);
    reason = fmt::format("crashed with signal {} ({}) {}", sig, strsignal(sig), where);
  } else {
    reason = fmt::format("exited with status {} {}", WEXITSTATUS(outcome.exit_status), where);
  }
  std::string log_tail;
  std::filesystem::path log = run_dir / "logs" / (cell.id + ".log");
  if (std::filesystem::exists(log)) {
    std::string text = io::read_text(log);
    log_tail = text.size() > 2000 ? text.substr(text.size() - 2000) : text;
  }
  json record = {{"schema_version", io::kResultsSchemaVersion}, {"cell", cell.id}, {"scene", cell.scene},
                 {"technique", cell.technique}, {"params", cell.params}, {"status", "failed"},
                 {"reason", reason}, {"failed_frame", failed_frame}, {"warnings", json::array()},
                 {"log_tail", log_tail}};
  io::write_text_atomic(dir / "cell.json", record.dump(2) + "\n");
}

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

void render_needed_references(const config::Config& config, const std::vector<config::Cell>& cells,
                              PluginRegistry& plugins) {
  std::vector<uint32_t> frames = metric_frames(config);
  if (frames.empty()) return;
  // Classes per scene file and reference depth: the full reference and, when the config asks for
  // them, the bounce-matched ones of the cells' techniques (scored_references).
  std::map<std::pair<std::filesystem::path, uint32_t>, uint32_t> masks;
  for (const auto& cell : cells) {
    const Plugin* plugin = plugins.find(cell.technique);
    if (!plugin || !plugin->loaded()) continue;
    const uint32_t classes = reference_classes(plugin->descriptor->path_class);
    for (const ScoredReference& ref : scored_references(config, cell.params))
      masks[{cell.scene_file, ref.options.max_bounces}] |= classes;
  }
  trace::ReferenceCache cache(config.reference.cache_dir);
  for (const auto& [key, mask] : masks) {
    const auto& [file, bounces] = key;
    trace::ReferenceOptions options = reference_options(config);
    options.max_bounces = bounces;
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

namespace {

}  // namespace

void write_summary(const std::filesystem::path& run_dir) {
  std::vector<json> records;
  std::set<std::string> params, passes;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(run_dir / "cells", ec)) {
    auto file = entry.path() / "cell.json";
    if (entry.path().filename().string().rfind(".partial-", 0) == 0 || !std::filesystem::exists(file)) continue;
    records.push_back(json::parse(io::read_text(file)));
    for (const auto& [k, v] : records.back()["params"].items()) params.insert(k);
    if (records.back().contains("summary"))
      for (const auto& [k, v] : records.back()["summary"]["pass_ms_median"].items()) passes.insert(k);
  }
  std::sort(records.begin(), records.end(), [](const json& a, const json& b) { return a["cell"] < b["cell"]; });
  std::vector<std::string> header = {"cell", "scene", "technique", "status", "frames", "frame_ms_median",
                                     "frame_ms_p5", "frame_ms_p95", "flip_mean", "ssim_mean", "psnr_mean",
                                     "flip_floor", "ssim_floor", "psnr_floor",
                                     "harness_overhead_pct"};
  for (const auto& p : params) header.push_back("param." + p);
  for (const auto& p : passes) header.push_back("pass." + p + ".ms_median");
  header.push_back("reason");
  std::string text = io::csv_row(header);
  for (const json& r : records) {
    json summary = r.value("summary", json::object());
    json frame = summary.value("frame_ms", json::object());
    json combined = r.value("metrics", json::object()).value("combined", json::object());
    std::vector<std::string> row = {r["cell"], r["scene"], r["technique"], r["status"],
                                    std::to_string(r.value("frames_measured", 0)),
                                    fmt_or_empty(frame.value("median", json())), fmt_or_empty(frame.value("p5", json())),
                                    fmt_or_empty(frame.value("p95", json())), fmt_or_empty(combined.value("flip", json())),
                                    fmt_or_empty(combined.value("ssim", json())), fmt_or_empty(combined.value("psnr", json())),
                                    fmt_or_empty(combined.value("flip_floor", json())),
                                    fmt_or_empty(combined.value("ssim_floor", json())),
                                    fmt_or_empty(combined.value("psnr_floor", json())),
                                    fmt_or_empty(summary.value("harness_overhead_pct", json()))};
    for (const auto& p : params) row.push_back(r["params"].value(p, ""));
    for (const auto& p : passes) row.push_back(fmt_or_empty(summary.value("pass_ms_median", json::object()).value(p, json())));
    row.push_back(r.value("reason", ""));
    text += io::csv_row(row);
  }
  io::write_text_atomic(run_dir / "summary.csv", text);
}

int run_benchmark(const RunOptions& options) {
  config::Config config = config::load_config(options.config_file, options.overrides);
  PluginRegistry plugins(config.plugin_dirs);
  std::vector<config::Cell> cells = config::expand_cells(config, plugins);

  std::filesystem::path run_dir = options.out_dir;
  if (options.resume) {
    if (run_dir.empty()) throw InputError("--resume needs --out DIR, the run folder to continue");
    Invocation previous = read_invocation(run_dir);
    if (previous.config_hash != config.hash)
      throw InputError(fmt::format("--resume: {} was run with a different config (hash {}, now {}); "
                                   "resume with the same config and --set values",
                                   run_dir.string(), previous.config_hash, config.hash));
  } else {
    if (run_dir.empty()) {
      auto now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
      run_dir = std::filesystem::path("results") / fmt::format("{}-{:%Y%m%d-%H%M%S}", config.name, fmt::localtime(now));
    }
    if (std::filesystem::exists(run_dir / "run.json"))
      throw InputError(fmt::format("{} already holds a run; use --resume to continue it, or another --out",
                                   run_dir.string()));
  }
  std::filesystem::create_directories(run_dir / "cells");
  run_dir = std::filesystem::canonical(run_dir);
  write_invocation(run_dir, {std::filesystem::absolute(options.config_file), options.overrides, config.hash});

  // The device is opened once here to record it and to reject a bad --device before any cell runs.
  std::string device_name, driver;
  bool fenced_timing = false;
  {
    gpu::Device device({options.device, false});
    device_name = device.name();
    driver = device.driver();
    fenced_timing = device.raster_timestamps_unreliable();
  }
  utsname uts{};
  uname(&uts);
  json run = {{"schema_version", io::kResultsSchemaVersion},
              {"tool_version", PB_VERSION},
              {"git_commit", command_output(fmt::format("git -C '{}' rev-parse HEAD 2>/dev/null", PB_SOURCE_DIR))},
              {"config_file", std::filesystem::absolute(options.config_file).string()},
              {"overrides", options.overrides},
              {"config_hash", config.hash},
              {"config", config.canonical},
              {"device", device_name},
              {"driver", driver},
              {"cpu", cpu_model()},
              {"cpu_count", sysconf(_SC_NPROCESSORS_ONLN)},
              {"os", fmt::format("{} {} {}", uts.sysname, uts.release, uts.machine)},
              // tests/unit/timing_test.cpp: on lavapipe, timestamps miss binned raster work, so every
              // pass is timed with fences there (each pass boundary submits and waits).
              {"timing", fenced_timing
                             ? "fenced: each pass boundary submits and waits; gpu_ms is fenced wall time "
                               "(lavapipe timestamps miss rasterisation)"
                             : "gpu timestamps per pass, bracketed by full barriers; cpu monotonic clock"},
              {"cells", cells.size()},
              {"start", now_iso()},
              {"end", nullptr}};
  if (std::filesystem::exists(run_dir / "run.json")) {
    json previous = json::parse(io::read_text(run_dir / "run.json"));
    run["start"] = previous.value("start", run["start"]);
    run["resumed"] = now_iso();
  }
  io::write_text_atomic(run_dir / "run.json", run.dump(2) + "\n");
  std::fprintf(stderr, "photonbench: %zu cells -> %s\n", cells.size(), run_dir.string().c_str());

  render_needed_references(config, cells, plugins);
  Progress progress(cells.size());
  int failed = 0, skipped = 0;
  for (size_t i = 0; i < cells.size(); ++i) {
    const config::Cell& cell = cells[i];
    std::filesystem::path done = cell_dir(run_dir, cell.id) / "cell.json";
    if (options.resume && std::filesystem::exists(done)) {
      json record = json::parse(io::read_text(done));
      failed += record["status"] != "ok";
      ++skipped;
      progress.finish(i, cell.id, "complete already, skipped");
      continue;
    }
    ChildOutcome outcome = run_child(run_dir, cell, options, config.limits.cell_seconds, progress, i);
    bool wrote = std::filesystem::exists(done) && !outcome.timed_out && WIFEXITED(outcome.exit_status) &&
                 WEXITSTATUS(outcome.exit_status) == 0;
    if (!wrote) record_abnormal_end(run_dir, cell, outcome, config.limits.cell_seconds);
    json record = json::parse(io::read_text(done));
    bool ok = record["status"] == "ok";
    failed += !ok;
    std::string outcome_text =
        ok ? fmt::format("ok, frame median {:.2f} ms",
                         record["summary"]["frame_ms"].value("median", 0.0))
           : "FAILED: " + record.value("reason", std::string("?"));
    progress.finish(i, cell.id, outcome_text);
    write_summary(run_dir);
  }
  write_summary(run_dir);
  run["end"] = now_iso();
  io::write_text_atomic(run_dir / "run.json", run.dump(2) + "\n");
  std::fprintf(stderr, "photonbench: %zu cells, %d failed%s. Summary: %s\n", cells.size(), failed,
               skipped ? fmt::format(", {} already complete", skipped).c_str() : "",
               (run_dir / "summary.csv").string().c_str());
  return failed ? 1 : 0;
}

}  // namespace pb::run
