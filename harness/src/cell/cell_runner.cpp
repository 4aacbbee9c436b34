#include "cell/cell_runner.h"

#include <fmt/format.h>

#include <cstdio>

#include "cell/cell_record.h"
#include "cell/extra_cells.h"
#include "cell/frame_log.h"
#include "cell/frame_loop.h"
#include "cell/invocation.h"
#include "cell/scoring.h"
#include "gpu/device_accounting.h"
#include "io/clock.h"
#include "plan/plan.h"

namespace pb::run {

std::filesystem::path cell_dir(const std::filesystem::path& run_dir, const std::string& id) {
  return run_dir / "cells" / id;
}

std::filesystem::path partial_cell_dir(const std::filesystem::path& run_dir,
                                       const std::string& id) {
  return run_dir / "cells" / (".partial-" + id);
}

namespace {

const Plugin& loaded_plugin(PluginRegistry& plugins, const std::string& technique) {
  const Plugin* plugin = plugins.find(technique);
  if (!plugin || !plugin->loaded())
    throw CellFailure{fmt::format("technique plugin '{}' failed to load: {}", technique,
                                  plugin ? plugin->load_error : "not found"),
                      std::nullopt};
  return *plugin;
}

// Each stage's wall-clock time as it ends (CellRecord::stages_ms), from the cell process's start.
class StageClock {
 public:
  void lap(const char* stage) {
    times_[stage] = 1e3 * io::seconds_since(last_);
    last_ = std::chrono::steady_clock::now();
  }
  const nlohmann::json& times() const { return times_; }

 private:
  nlohmann::json times_ = nlohmann::json::object();
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

// Tells the parent which stage a crash from here on happened in (cell_process.h: "@stage NAME").
void announce_stage(const char* stage) {
  std::printf("@stage %s\n", stage);
  std::fflush(stdout);
}

// The technique made and set up. setup() may record GPU work (uploads, clears); it runs outside
// any timed frame, and its warnings are the cell's.
TechniqueInstance set_up_technique(const Plugin& plugin, const Cell& cell, Renderer& r,
                                   CellRecord& record) {
  TechniqueInstance technique = create_technique(*plugin.descriptor);
  r.ctx.declare_counters({plugin.descriptor->counters, plugin.descriptor->counter_count});
  r.commands.begin();
  technique->setup(r.ctx, Params(cell.params));
  r.commands.submit_and_wait();
  r.commands.end_frame();
  for (const std::string& warning : r.ctx.warnings()) record.warn(std::nullopt, warning);
  return technique;
}

// The cell's stages after its folder is made: plugin, renderer, technique, frames, scoring. What
// each stage learns goes into `record` as it is learnt, so a failure keeps everything before it.
void run_stages(const RunPlan& plan, const Cell& cell, const CellRunOptions& options,
                const std::filesystem::path& dir, CellRecord& record, FrameLog& log,
                StageClock& stages) {
  const config::Config& config = plan.config;
  const Plugin& plugin = loaded_plugin(*plan.plugins, cell.technique);
  const std::string path_class = plugin.descriptor->path_class;
  record.path_class = path_class;

  Renderer r({options.device, options.validation}, scene::load_scene(cell.scene_file), config.width,
             config.height);
  r.world.set_seed(cell.seed, cell.seed_index);
  record.device = r.device.name();
  record.timing = r.profiler.fenced() ? "fenced" : "timestamps";
  if (!config.testing.slow_pass.empty())
    r.profiler.slow_down(config.testing.slow_pass, config.testing.slow_factor);

  // The technique is set up at the first frame the cell plays (frames.start - warmup).
  if (config.frames.first_frame() > 0) {
    r.commands.begin();
    r.world.advance_to(config.frames.first_frame());
    r.commands.submit_and_wait();
    r.commands.end_frame();
  }
  const uint64_t harness_gpu_bytes = gpu::DeviceAccounting::allocated_bytes(r.device);
  stages.lap("startup");
  TechniqueInstance technique = set_up_technique(plugin, cell, r, record);
  stages.lap("setup");
  FrameLoop frames(config, r, log, record, dir, trace::reference_class_of(path_class),
                   harness_gpu_bytes);
  const std::vector<uint32_t> written = frames.run(*technique);
  stages.lap("frames");

  // Scoring against references: after the frames, never on the timed path.
  announce_stage("scoring");
  ScoreResult scores =
      score_cell(config, cell, r.world.scene(), written, path_class, dir, frames.class_outputs());
  for (const std::string& warning : scores.warnings) record.warn(std::nullopt, warning);
  record.metrics = scores.means;
  if (!scores.bounce_matched_means.is_null())
    record.metrics_bounce_matched = scores.bounce_matched_means;
  record.references = scores.references;
  stages.lap("scoring");
  // What follows is the locals' destruction: the technique's, then the renderer's.
  announce_stage("teardown");
}

}  // namespace

int run_cell(const CellRunOptions& options) {
  StageClock stages;
  const Invocation invocation = read_invocation(options.run_dir);
  const RunPlan plan = plan_run(invocation.config_file, invocation.overrides);
  // A match run's probe, seed or round cell is not in the plan: the run folder lists it.
  const std::optional<Cell> extra =
      plan.find(options.cell_id) ? std::nullopt : find_extra_cell(options.run_dir, options.cell_id);
  const Cell& cell = extra ? *extra : plan.cell(options.cell_id);

  const std::filesystem::path dir = partial_cell_dir(options.run_dir, cell.id);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "images");

  CellRecord record(cell);
  record.validation = options.validation;
  stages.lap("plan");
  {
    FrameLog log(dir);
    try {
      run_stages(plan, cell, options, dir, record, log, stages);
      stages.lap("teardown");
    } catch (const CellFailure& failure) {
      record.fail(failure);
    } catch (const std::exception& e) {
      record.fail({fmt::format("error: {}", e.what()), std::nullopt});
    }
    log.describe(record);
  }
  record.stages_ms = stages.times();
  write_cell_record(dir, record);

  // Complete: the partial folder becomes the cell's folder in one rename.
  const std::filesystem::path final_dir = cell_dir(options.run_dir, cell.id);
  std::filesystem::remove_all(final_dir);
  std::filesystem::rename(dir, final_dir);
  return 0;
}

}  // namespace pb::run
