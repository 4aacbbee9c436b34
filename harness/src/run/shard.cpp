#include "run/shard.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cstdlib>
#include <numeric>

#include "cell/scoring.h"
#include "io/results.h"
#include "photonbench/error.h"

namespace pb::run {

namespace {

// Per-unit times fitted to cells measured on lavapipe, 2 cores (docs/architecture.md, Sharding), in
// seconds. A photon technique's frame costs per light path (tracing, upload, building its
// structure) and per light path and pixel (each photon covers a screen area that grows with the
// resolution at a fixed world radius).
constexpr double kStartupSeconds = 2.0;             // process, device, scene, technique setup
constexpr double kPixelFrameSeconds = 6.1e-7;       // one pixel of one frame, any technique
constexpr double kPathFrameSeconds = 1.4e-5;        // one light path of one frame
constexpr double kPathPixelFrameSeconds = 3.6e-10;  // one light path times one pixel, one frame
constexpr double kScoredPixelSeconds = 1.0e-5;      // one pixel of one reference class scored

uint32_t parse_positive(const std::string& text) {
  if (text.empty() || text.size() > 9 ||
      !std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return 0;
  return uint32_t(std::stoul(text));
}

// The light paths a cell traces per frame: its parameters whose unit is "paths".
double light_paths(const Cell& cell, PluginRegistry& plugins) {
  const Plugin* plugin = plugins.find(cell.technique);
  if (!plugin || !plugin->loaded()) return 0;
  double paths = 0;
  const pb_technique_descriptor& d = *plugin->descriptor;
  for (uint32_t i = 0; i < d.param_count; ++i) {
    const pb_param_spec& spec = d.params[i];
    auto value = cell.params.find(spec.name);
    if (spec.unit && std::string(spec.unit) == "paths" && value != cell.params.end())
      paths += std::strtod(value->second.c_str(), nullptr);
  }
  return paths;
}

// The reference classes a cell is scored against, each once per reference (full, bounce-matched).
int scored_classes(const config::Config& config, const Cell& cell, PluginRegistry& plugins) {
  const Plugin* plugin = plugins.find(cell.technique);
  if (!plugin || !plugin->loaded()) return 0;
  const uint32_t classes = reference_classes(plugin->descriptor->path_class);
  return int(std::popcount(classes) * scored_references(config, cell).size());
}

}  // namespace

std::string ShardSpec::text() const { return fmt::format("{}/{}", index, count); }

ShardSpec parse_shard(const std::string& text) {
  const size_t slash = text.find('/');
  ShardSpec spec;
  if (slash != std::string::npos) {
    spec.index = parse_positive(text.substr(0, slash));
    spec.count = parse_positive(text.substr(slash + 1));
  }
  if (spec.index == 0 || spec.count == 0 || spec.index > spec.count)
    throw InputError(
        fmt::format("--shard: '{}' is not I/N, shard I of N with 1 <= I <= N (e.g. 2/4)", text));
  return spec;
}

double estimate_cell_cost(const config::Config& config, const Cell& cell, PluginRegistry& plugins) {
  const double pixels = double(config.width) * config.height;
  const double frames = double(config.frames.warmup) + config.frames.count;
  const double paths = light_paths(cell, plugins);
  const double frame_cost = pixels * kPixelFrameSeconds + paths * kPathFrameSeconds +
                            paths * pixels * kPathPixelFrameSeconds;
  const double scoring = double(metric_frames(config).size()) * pixels *
                         scored_classes(config, cell, plugins) * kScoredPixelSeconds;
  return kStartupSeconds + frames * frame_cost + scoring;
}

std::vector<uint32_t> assign_shards(const std::vector<std::string>& ids,
                                    const std::vector<double>& costs, uint32_t count) {
  std::vector<size_t> order(ids.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return costs[a] != costs[b] ? costs[a] > costs[b] : ids[a] < ids[b];
  });
  std::vector<double> load(count, 0.0);
  std::vector<uint32_t> shard_of(ids.size(), 0);
  for (size_t cell : order) {
    // min_element returns the first of equal loads: ties go to the lower shard.
    const auto lightest = std::min_element(load.begin(), load.end());
    shard_of[cell] = uint32_t(lightest - load.begin());
    *lightest += costs[cell];
  }
  return shard_of;
}

ShardSelection select_shard(const RunPlan& plan, const ShardSpec& shard) {
  ShardSelection selection;
  std::vector<std::string> ids;
  std::vector<double> costs;
  for (const Cell& cell : plan.cells) {
    ids.push_back(cell.id);
    costs.push_back(estimate_cell_cost(plan.config, cell, *plan.plugins));
  }
  selection.every = ids;
  selection.total_cost = std::accumulate(costs.begin(), costs.end(), 0.0);
  const std::vector<uint32_t> shard_of = shard.sharded() ? assign_shards(ids, costs, shard.count)
                                                         : std::vector<uint32_t>(ids.size(), 0);
  for (size_t i = 0; i < plan.cells.size(); ++i) {
    if (shard.sharded() && shard_of[i] != shard.index - 1) continue;
    selection.cells.push_back(plan.cells[i]);
    selection.costs.push_back(costs[i]);
    selection.shard_cost += costs[i];
  }
  return selection;
}

nlohmann::json describe_shard(const ShardSpec& shard, const ShardSelection& selection) {
  std::vector<std::string> ids;
  for (const Cell& cell : selection.cells) ids.push_back(cell.id);
  char host[256] = {};
  gethostname(host, sizeof host - 1);
  nlohmann::json j = {{"index", shard.index},
                      {"count", shard.count},
                      {"cells", ids},
                      {"estimated_share", selection.share()},
                      {"every_cell", selection.every},
                      {"host", host}};
  // Under Slurm, which job and array task ran this shard (for its log and accounting).
  for (const char* name : {"SLURM_JOB_ID", "SLURM_ARRAY_JOB_ID", "SLURM_ARRAY_TASK_ID"})
    if (const char* value = std::getenv(name)) j["slurm"][name] = value;
  return j;
}

void check_resumed_shard(const std::filesystem::path& run_dir, const ShardSpec& shard) {
  const std::filesystem::path file = run_dir / "run.json";
  if (!std::filesystem::exists(file)) return;  // stopped before its run.json: nothing to compare
  const nlohmann::json previous =
      nlohmann::json::parse(io::read_text(file)).value("shard", nlohmann::json());
  const std::string was = previous.is_object() ? fmt::format("{}/{}", previous.value("index", 0u),
                                                             previous.value("count", 0u))
                                               : std::string("unsharded");
  const std::string now = shard.sharded() ? shard.text() : std::string("unsharded");
  if (was != now)
    throw InputError(
        fmt::format("--resume: {} was started as shard {}, not {}; resume it with the same --shard",
                    run_dir.string(), was, now));
}

}  // namespace pb::run
