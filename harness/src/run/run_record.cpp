#include "run/run_record.h"

#include <fmt/chrono.h>
#include <fmt/format.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <iterator>

#include "build_commit.h"  // generated: PB_BUILD_COMMIT
#include "io/results.h"
#include "photonbench/gpu.h"

namespace pb::run {

using json = nlohmann::json;

namespace {

std::string cpu_model() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);)
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown";
}

// Which build of each technique the run loads: the module's path, a hash of its bytes (a rebuilt
// plugin is another plugin, whatever its name) and the plugin API version it declares.
json describe_plugins(const RunPlan& plan) {
  json plugins = json::object();
  for (const Cell& cell : plan.cells) {
    if (plugins.contains(cell.technique)) continue;
    const Plugin* plugin = plan.plugins->find(cell.technique);
    if (!plugin) continue;
    std::error_code ec;
    const std::filesystem::path path = std::filesystem::canonical(plugin->file, ec);
    std::ifstream in(plugin->file, std::ios::binary);
    const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    json record = {{"path", (ec ? plugin->file : path).string()},
                   {"fnv1a64", config::stable_hash(bytes)},
                   {"api_version",
                    plugin->descriptor ? json(plugin->descriptor->api_version) : json(nullptr)}};
    if (!plugin->loaded()) record["load_error"] = plugin->load_error;
    plugins[cell.technique] = std::move(record);
  }
  return plugins;
}

}  // namespace

std::string now_iso() {
  auto now = std::chrono::system_clock::now();
  return fmt::format("{:%Y-%m-%dT%H:%M:%S}Z",
                     fmt::gmtime(std::chrono::system_clock::to_time_t(now)));
}

json describe_run(const std::filesystem::path& config_file,
                  const std::vector<std::string>& overrides, const std::string& device_filter,
                  const RunPlan& plan, const std::filesystem::path& run_dir) {
  std::string device_name, driver;
  bool fenced_timing = false;
  {
    gpu::Device device({device_filter, false});
    device_name = device.name();
    driver = device.driver();
    fenced_timing = device.raster_timestamps_unreliable();
  }
  utsname uts{};
  uname(&uts);
  json run = {
      {"schema_version", io::kResultsSchemaVersion},
      {"tool_version", PB_VERSION},
      // The binary's own commit (cmake/build_commit.cmake), not whatever the checkout holds when
      // the run starts: a figure belongs to the code that measured it.
      {"git_commit", PB_BUILD_COMMIT},
      {"config_file", std::filesystem::absolute(config_file).string()},
      {"overrides", overrides},
      {"config_hash", plan.config.hash},
  // What else a time depends on besides the code (tools/pbtools/environment.py compares them).
#ifdef NDEBUG
      {"build", {{"type", PB_BUILD_TYPE}, {"ndebug", true}}},
#else
      {"build", {{"type", PB_BUILD_TYPE}, {"ndebug", false}}},
#endif
      {"config", plan.config.canonical},
      {"resolution", {plan.config.width, plan.config.height}},  // after any --set
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
      {"cells", plan.cells.size()},
      {"resolve_factor", kResolveFactor},
      {"plugins", describe_plugins(plan)},
      {"start", now_iso()},
      {"end", nullptr}};
  if (std::filesystem::exists(run_dir / "run.json")) {
    json previous = json::parse(io::read_text(run_dir / "run.json"));
    run["start"] = previous.value("start", run["start"]);
    run["resumed"] = now_iso();
  }
  return run;
}

}  // namespace pb::run
