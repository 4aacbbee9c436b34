#include "run/cell_runner.h"

#include <fmt/format.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "config/config.h"
#include "gpu/shared_passes.h"
#include "io/image.h"
#include "io/results.h"
#include "photonbench/error.h"
#include "run/invocation.h"
#include "run/plugins.h"
#include "run/profiler.h"
#include "run/scoring.h"
#include "run/stats.h"
#include "scene/scene.h"
#include "trace/embree_scene.h"
#include "trace/photon_tracer.h"

namespace pb::run {

using json = nlohmann::json;

std::filesystem::path cell_dir(const std::filesystem::path& run_dir, const std::string& id) {
  return run_dir / "cells" / id;
}

std::filesystem::path partial_cell_dir(const std::filesystem::path& run_dir, const std::string& id) {
  return run_dir / "cells" / (".partial-" + id);
}

namespace {

// Why a cell failed, and at which frame; thrown inside the frame loop, caught once.
struct CellFailure {
  std::string reason;
  int64_t frame;
};

// The context a technique renders through: the frame's command buffer, pass scopes, counters, warnings.
class FrameContext final : public Context {
 public:
  FrameContext(gpu::Device& device) : device_(device) {
    pool_ = vk::raii::CommandPool(device.device(), {vk::CommandPoolCreateFlagBits::eResetCommandBuffer,
                                                    device.queue_family()});
    fence_ = vk::raii::Fence(device.device(), vk::FenceCreateInfo{});
  }

  void attach(gpu::ScenePasses* passes, Profiler* profiler, const scene::Scene* scene) {
    passes_ = passes, profiler_ = profiler, scene_ = scene;
  }

  // The Embree world exists only for techniques that trace photons; others pay nothing for it.
  void update_world(const scene::FrameState& state) {
    state_ = state;
    if (world_) world_->update(state);
  }

  // Command buffers are reused frame after frame (allocation is measurable overhead on lavapipe).
  void begin_recording() {
    if (used_ == buffers_.size())
      buffers_.emplace_back(std::move(vk::raii::CommandBuffers(
          device_.device(), {*pool_, vk::CommandBufferLevel::ePrimary, 1})[0]));
    current_ = *buffers_[used_++];
    current_.begin(vk::CommandBufferBeginInfo{vk::CommandBufferUsageFlagBits::eOneTimeSubmit});
  }

  void submit_and_wait() {
    current_.end();
    device_.queue().submit(vk::SubmitInfo{{}, {}, current_}, *fence_);
    if (device_.device().waitForFences(*fence_, VK_TRUE, UINT64_MAX) != vk::Result::eSuccess)
      throw Error("waiting for the frame's fence failed");
    device_.device().resetFences(*fence_);
    current_ = nullptr;
  }

  void end_frame_buffers() {
    pool_.reset();
    used_ = 0;
  }

  // Context
  gpu::Device& gpu() override { return device_; }
  vk::CommandBuffer cmd() override { return current_; }
  void flush() override {
    // What the GPU wrote so far becomes visible to the host (mapped counters, read-backs).
    vk::MemoryBarrier to_host{vk::AccessFlagBits::eMemoryWrite, vk::AccessFlagBits::eHostRead};
    current_.pipelineBarrier(vk::PipelineStageFlagBits::eAllCommands, vk::PipelineStageFlagBits::eHost, {},
                             to_host, {}, {});
    submit_and_wait();
    begin_recording();
  }
  PassScope pass(std::string_view name) override { return PassScope(profiler_, profiler_->begin_pass(name)); }
  void count(std::string_view name, double value) override { counters_.emplace_back(std::string(name), value); }
  void warn(std::string_view message) override { warnings_.emplace_back(std::string(message)); }
  const FrameInfo& frame() const override { return frame_; }
  SharedPasses& shared() override { return *passes_; }
  trace::PhotonTracer& photon_tracer() override {
    if (!tracer_) {
      world_ = std::make_unique<trace::EmbreeScene>(*scene_, state_);
      tracer_ = trace::make_photon_tracer(*world_);
    }
    return *tracer_;
  }
  const gpu::Image& output() override { return passes_->output(); }

  FrameInfo frame_{};
  std::vector<std::pair<std::string, double>> counters_;
  std::vector<std::string> warnings_;

 private:
  gpu::Device& device_;
  gpu::ScenePasses* passes_ = nullptr;
  Profiler* profiler_ = nullptr;
  const scene::Scene* scene_ = nullptr;
  scene::FrameState state_;
  std::unique_ptr<trace::EmbreeScene> world_;
  std::unique_ptr<trace::PhotonTracer> tracer_;
  vk::raii::CommandPool pool_{nullptr};
  vk::raii::Fence fence_{nullptr};
  std::vector<vk::raii::CommandBuffer> buffers_;
  size_t used_ = 0;
  vk::CommandBuffer current_ = nullptr;
};

struct TechniqueDeleter {
  void (*destroy)(void*);
  void operator()(Technique* t) const {
    if (t) destroy(t);
  }
};

uint64_t peak_host_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return uint64_t(usage.ru_maxrss) * 1024;  // Linux reports kilobytes
}

std::string ms_text(double ms) { return fmt::format("{:.4f}", ms); }

// The technique's indirect estimate alone (what it handed to shade()), written next to the frame so that
// its path class is scored by itself rather than only inside the combined image. Background pixels are
// zeroed as shade() zeroes them (a technique need not clear its estimate where there is no surface).
void write_class_estimate(gpu::Device& device, const gpu::ScenePasses& passes, const std::filesystem::path& file) {
  std::vector<float> estimate, position;
  device.read_image(*passes.indirect_estimate(), estimate);
  device.read_image(*passes.gbuffer_images().position, position);
  for (size_t i = 0; i + 3 < estimate.size(); i += 4) {
    if (position[i + 3] <= 0.f) estimate[i] = estimate[i + 1] = estimate[i + 2] = 0.f;
    estimate[i + 3] = 1.f;
  }
  const auto extent = passes.indirect_estimate()->extent();
  io::Image image(int(extent.width), int(extent.height), 4);
  image.pixels = std::move(estimate);
  io::write_image(file, image);
}

}  // namespace

int run_cell(const CellRunOptions& options) {
  Invocation invocation = read_invocation(options.run_dir);
  config::Config config = config::load_config(invocation.config_file, invocation.overrides);
  PluginRegistry plugins(config.plugin_dirs);
  std::vector<config::Cell> cells = config::expand_cells(config, plugins);
  auto cell_it = std::find_if(cells.begin(), cells.end(), [&](const auto& c) { return c.id == options.cell_id; });
  if (cell_it == cells.end()) throw InputError(fmt::format("no cell '{}' in {}", options.cell_id, config.file.string()));
  const config::Cell& cell = *cell_it;

  std::filesystem::path dir = partial_cell_dir(options.run_dir, cell.id);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "images");

  json record = {{"schema_version", io::kResultsSchemaVersion}, {"cell", cell.id}, {"scene", cell.scene},
                 {"technique", cell.technique}, {"params", cell.params}, {"status", "ok"}, {"reason", ""},
                 {"failed_frame", nullptr}};
  json warnings = json::array();
  io::CsvAppender frames_csv(dir / "frames.csv", {"frame", "pass", "gpu_ms", "cpu_ms", "process_cpu_ms"});
  io::CsvAppender counters_csv(dir / "counters.csv", {"frame", "name", "value"});
  std::vector<double> frame_ms, overhead_ms;
  std::map<std::string, std::vector<double>> pass_ms;
  std::vector<uint32_t> written_frames;
  uint64_t gpu_bytes_technique = 0, gpu_bytes_total = 0;
  const uint32_t total_frames = config.frames.warmup + config.frames.count;
  int64_t current_frame = -1;
  std::string validation_note;

  try {
    const Plugin* plugin = plugins.find(cell.technique);
    if (!plugin || !plugin->loaded())
      throw CellFailure{fmt::format("technique plugin '{}' failed to load: {}", cell.technique,
                                    plugin ? plugin->load_error : "not found"), -1};
    record["path_class"] = plugin->descriptor->path_class;
    const std::optional<trace::PathClass> own_class = reference_class_of(plugin->descriptor->path_class);

    scene::Scene scene = scene::load_scene(cell.scene_file);
    gpu::Device device({options.device, options.validation});
    record["device"] = device.name();
    FrameContext ctx(device);
    Profiler profiler(device, [&] { return ctx.cmd(); });
    gpu::ScenePasses passes(device, scene, config.width, config.height, {}, profiler, [&] { return ctx.cmd(); });
    if (device.raster_timestamps_unreliable()) {
      profiler.use_fenced_timing([&] {
        auto start = std::chrono::steady_clock::now();
        ctx.flush();
        return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      });
    }
    record["timing"] = profiler.fenced() ? "fenced" : "timestamps";
    ctx.attach(&passes, &profiler, &scene);
    ctx.update_world(scene.at(0));

    if (!config.testing.slow_pass.empty()) profiler.slow_down(config.testing.slow_pass, config.testing.slow_factor);

    uint64_t bytes_before = device.allocated_bytes();
    std::unique_ptr<Technique, TechniqueDeleter> technique(
        static_cast<Technique*>(plugin->descriptor->create()), TechniqueDeleter{plugin->descriptor->destroy});
    Params params(cell.params);
    {
      // setup() may record GPU work (uploads, clears); it runs outside any timed frame.
      ctx.begin_recording();
      technique->setup(ctx, params);
      ctx.submit_and_wait();
      ctx.end_frame_buffers();
    }

    std::vector<float> rgba;
    const std::vector<uint32_t> scored = run::metric_frames(config);
    for (uint32_t f = 0; f < total_frames; ++f) {
      current_frame = f;
      bool warmup = f < config.frames.warmup;
      bool metric_frame = std::find(scored.begin(), scored.end(), f) != scored.end();
      ctx.counters_.clear();
      ctx.warnings_.clear();

      // ---- timed region: scene-update, the technique's passes, submission and the fence ----
      auto frame_start = std::chrono::steady_clock::now();
      double frame_process_start = process_cpu_ms();  // CPU time of every thread (profiler.h)
      profiler.begin_frame();
      ctx.begin_recording();
      scene::FrameState state;
      {
        auto scope = ctx.pass("scene-update");
        state = scene.at(f);
        passes.update(state);
        ctx.update_world(state);
      }
      ctx.frame_ = FrameInfo{f, state.time, warmup, config.width, config.height, passes.camera_view()};
      technique->render(ctx);
      ctx.submit_and_wait();
      double wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - frame_start).count();
      double frame_process_ms = process_cpu_ms() - frame_process_start;
      // ---- end of timed region ----
      std::vector<PassSample> samples = profiler.end_frame();
      ctx.end_frame_buffers();

      // Harness overhead: the frame's wall time less what the passes themselves took, counting a pass's
      // CPU time (its recording, or its CPU work) and its GPU time (its execution) as its own. What is
      // left is the harness's: pass bookkeeping, submission and the fence.
      double passes_ms = 0;
      for (const auto& s : samples)
        if (s.depth == 0) passes_ms += s.cpu_ms + s.gpu_ms;
      double overhead = std::max(0.0, wall_ms - passes_ms);
      double passes_process_ms = 0;  // the same split of the frame's process CPU time
      for (const auto& s : samples)
        if (s.depth == 0) passes_process_ms += s.process_cpu_ms;
      double overhead_process = std::max(0.0, frame_process_ms - passes_process_ms);
      gpu_bytes_total = std::max<uint64_t>(gpu_bytes_total, device.allocated_bytes());
      gpu_bytes_technique = std::max<uint64_t>(gpu_bytes_technique, device.allocated_bytes() - bytes_before);
      if (!warmup) {
        for (const auto& s : samples) {
          frames_csv.row({std::to_string(f), s.name, ms_text(s.gpu_ms), ms_text(s.cpu_ms),
                          ms_text(s.process_cpu_ms)});
          pass_ms[s.name].push_back(s.ms());
        }
        frames_csv.row({std::to_string(f), "harness-overhead", "", ms_text(overhead),
                        ms_text(overhead_process)});
        frames_csv.row({std::to_string(f), "frame", "", ms_text(wall_ms), ms_text(frame_process_ms)});
        frame_ms.push_back(wall_ms);
        overhead_ms.push_back(overhead);
        for (const auto& [name, value] : ctx.counters_)
          counters_csv.row({std::to_string(f), name, fmt::format("{}", value)});
      }
      for (const auto& w : ctx.warnings_) warnings.push_back({{"frame", f}, {"message", w}});

      if (options.validation && device.validation_errors() > 0)
        throw CellFailure{"Vulkan validation error: " + device.first_validation_error(), f};

      // Read-back and checks happen outside the timed region.
      device.read_image(passes.output(), rgba);
      size_t bad = std::count_if(rgba.begin(), rgba.end(), [](float v) { return !std::isfinite(v); });
      if (bad > 0)
        throw CellFailure{fmt::format("the output image holds {} NaN or Inf values", bad), f};
      if (metric_frame) {
        io::Image image(int(config.width), int(config.height), 4);
        image.pixels = rgba;
        io::write_image(dir / "images" / fmt::format("frame_{:04d}.exr", f), image);
        io::write_image(dir / "images" / fmt::format("frame_{:04d}.png", f), io::display_encode(image));
        if (own_class && *own_class != trace::PathClass::direct && passes.indirect_estimate())
          write_class_estimate(device, passes, dir / "images" / class_image_name(f, *own_class));
        written_frames.push_back(f);
      }
      std::printf("@frame %u %u\n", f + 1, total_frames);
      std::fflush(stdout);
    }
    current_frame = -1;

    // Scoring against references: after the frames, never on the timed path.
    ScoreResult scores = score_cell(config, cell, scene, written_frames, plugin->descriptor->path_class, dir);
    for (const auto& w : scores.warnings) warnings.push_back({{"frame", nullptr}, {"message", w}});
    scores.record_into(record);
  } catch (const CellFailure& failure) {
    record["status"] = "failed";
    record["reason"] = failure.reason;
    if (failure.frame >= 0) record["failed_frame"] = failure.frame;
  } catch (const std::exception& e) {
    record["status"] = "failed";
    record["reason"] = current_frame >= 0 ? fmt::format("technique error at frame {}: {}", current_frame, e.what())
                                          : fmt::format("error: {}", e.what());
    if (current_frame >= 0) record["failed_frame"] = current_frame;
  }

  record["warnings"] = warnings;
  record["frames_measured"] = frame_ms.size();
  record["summary"] = {{"frame_ms", describe(frame_ms)}, {"harness_overhead_ms", describe(overhead_ms)}};
  json pass_medians = json::object();
  for (const auto& [name, values] : pass_ms) pass_medians[name] = percentile(values, 50);
  record["summary"]["pass_ms_median"] = pass_medians;
  double overhead_pct = 0;
  if (!frame_ms.empty()) overhead_pct = 100.0 * percentile(overhead_ms, 50) / std::max(percentile(frame_ms, 50), 1e-9);
  record["summary"]["harness_overhead_pct"] = overhead_pct;
  record["memory"] = {{"peak_host_bytes", peak_host_bytes()}, {"gpu_bytes_technique", gpu_bytes_technique},
                      {"gpu_bytes_total", gpu_bytes_total}};
  record["validation"] = options.validation;
  io::write_text_atomic(dir / "cell.json", record.dump(2) + "\n");

  // Complete: the partial folder becomes the cell's folder in one rename.
  std::filesystem::path final_dir = cell_dir(options.run_dir, cell.id);
  std::filesystem::remove_all(final_dir);
  std::filesystem::rename(dir, final_dir);
  return 0;
}

}  // namespace pb::run
