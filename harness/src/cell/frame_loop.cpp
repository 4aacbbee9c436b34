#include "cell/frame_loop.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "cell/scoring.h"
#include "cell/video_capture.h"
#include "gpu/device_accounting.h"
#include "io/image.h"

namespace pb::run {

namespace {

double ms_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

// An image of one path class alone, written next to the frame so that the class is scored by
// itself rather than only inside the combined image; alpha is set to 1.
void write_class_image(std::vector<float> rgba, vk::Extent2D extent,
                       const std::filesystem::path& file) {
  for (size_t i = 3; i < rgba.size(); i += 4) rgba[i] = 1.f;
  io::Image image(int(extent.width), int(extent.height), 4);
  image.pixels = std::move(rgba);
  io::write_image(file, image);
}

// The technique's indirect estimate alone (what it handed to shade()). Background pixels are
// zeroed as shade() zeroes them (a technique need not clear its estimate where there is no
// surface).
void write_class_estimate(gpu::Device& device, const gpu::ScenePasses& passes,
                          const std::filesystem::path& file) {
  std::vector<float> estimate, position;
  device.read_image(*passes.indirect_estimate(), estimate);
  device.read_image(*passes.gbuffer_images().position, position);
  for (size_t i = 0; i + 3 < estimate.size(); i += 4)
    if (position[i + 3] <= 0.f) estimate[i] = estimate[i + 1] = estimate[i + 2] = 0.f;
  write_class_image(std::move(estimate), passes.indirect_estimate()->extent(), file);
}

}  // namespace

Renderer::Renderer(const gpu::Device::Options& options, scene::Scene scene, uint32_t width,
                   uint32_t height)
    : device(options),
      commands(device),
      profiler(device, [this] { return commands.current(); }),
      world(device, std::move(scene), width, height, profiler,
            [this] { return commands.current(); }),
      ctx(device, commands, profiler, world) {
  world.passes().attach_host(
      {[this] { commands.flush(); },
       [this]() -> const trace::EmbreeScene& { return world.embree_scene(); },
       [this](const Counter& counter, double value) { ctx.count(counter, value); },
       [this] { return uint64_t(world.seed_scramble().value_or(0)); }});
  if (device.raster_timestamps_unreliable()) {
    profiler.use_fenced_timing([this] {
      const auto start = std::chrono::steady_clock::now();
      commands.flush();
      return ms_since(start);
    });
  }
}

FrameLoop::FrameLoop(const config::Config& config, Renderer& renderer, FrameLog& log,
                     CellRecord& record, const std::filesystem::path& cell_dir,
                     std::optional<trace::PathClass> own_class, uint64_t technique_gpu_bytes_from)
    : config_(config),
      renderer_(renderer),
      log_(log),
      record_(record),
      images_(cell_dir / "images"),
      video_(cell_dir / "video"),
      own_class_(own_class),
      technique_gpu_bytes_from_(technique_gpu_bytes_from) {}

std::vector<uint32_t> FrameLoop::run(Technique& technique) {
  const config::FrameSettings& frames = config_.frames;
  const uint32_t total = frames.warmup + frames.count;
  const std::vector<uint32_t> scored = metric_frames(config_);
  std::vector<uint32_t> written, video_frames;
  const bool video = captures_cell(config_.video, record_.cell.technique);
  for (uint32_t f = frames.first_frame(); f <= frames.last_frame(); ++f) {
    try {
      const bool warmup = !frames.measured(f);
      const FrameTiming timing = render_timed(technique, f, warmup);
      const uint64_t allocated = gpu::DeviceAccounting::allocated_bytes(renderer_.device);
      // The technique's share is what was allocated since it was created; the harness may free
      // its own staging memory meanwhile, so the total can fall below that mark (then 0, never an
      // unsigned wrap).
      const uint64_t technique_bytes =
          allocated > technique_gpu_bytes_from_ ? allocated - technique_gpu_bytes_from_ : 0;
      log_.track_gpu_memory(technique_bytes, allocated);
      if (!warmup) log_.add(timing, renderer_.ctx.counters());
      nlohmann::json declarations = nlohmann::json::object();
      for (const auto& [name, declared] : renderer_.ctx.counter_declarations())
        declarations[name] = {{"kind", counter_kind_name(declared.kind)}, {"unit", declared.unit}};
      if (!declarations.empty()) record_.counters = std::move(declarations);
      // A counter named as a parameter is the value the technique resolved it to (blur_radius: -1
      // is automatic); the last frame's is kept.
      for (const auto& [name, value] : renderer_.ctx.counters())
        if (record_.cell.params.count(name)) record_.resolved_params[name] = value;
      for (const std::string& warning : renderer_.ctx.warnings()) record_.warn(f, warning);
      check_output(f);
      // A video frame is the output check_output has just read back, after the timed region.
      if (video && captures_frame(config_.video, frames, f)) {
        write_video_frame(video_, f, rgba_, config_.width, config_.height);
        video_frames.push_back(f);
      }
      if (std::find(scored.begin(), scored.end(), f) != scored.end()) {
        write_images(f);
        written.push_back(f);
      }
    } catch (const CellFailure&) {
      throw;
    } catch (const std::exception& e) {
      throw CellFailure{fmt::format("technique error at frame {}: {}", f, e.what()), f};
    }
    std::printf("@frame %u %u\n", f - frames.first_frame() + 1, total);
    std::fflush(stdout);
  }
  if (video)
    write_video_index(video_, renderer_.world.scene().fps, config_.video, config_.width,
                      config_.height, video_frames);
  return written;
}

FrameTiming FrameLoop::render_timed(Technique& technique, uint32_t f, bool warmup) {
  FrameTiming timing;
  timing.frame = f;
  // ---- timed region: scene-update, the technique's passes, submission and the fence ----
  const auto start = std::chrono::steady_clock::now();
  const double process_start = process_cpu_ms();
  renderer_.profiler.begin_frame();
  renderer_.commands.begin();
  {
    auto scope = renderer_.ctx.pass("scene-update");
    renderer_.world.advance_to(f);
  }
  renderer_.ctx.begin_frame(FrameInfo{f, renderer_.world.state().time, warmup, config_.width,
                                      config_.height, renderer_.world.passes().camera_view()});
  technique.render(renderer_.ctx);
  renderer_.commands.submit_and_wait();
  timing.wall_ms = ms_since(start);
  timing.process_cpu_ms = process_cpu_ms() - process_start;
  // ---- end of timed region ----
  timing.passes = renderer_.profiler.end_frame();
  renderer_.commands.end_frame();
  return timing;
}

// Validation errors (counted only with the layers on) fail the cell at the frame that caused them;
// so does an output holding NaN or Inf, which would poison every metric.
void FrameLoop::check_output(uint32_t f) {
  if (renderer_.device.validation_errors() > 0)
    throw CellFailure{"Vulkan validation error: " + renderer_.device.first_validation_error(), f};
  renderer_.device.read_image(renderer_.world.passes().output(), rgba_);
  const size_t bad =
      std::count_if(rgba_.begin(), rgba_.end(), [](float v) { return !std::isfinite(v); });
  if (bad > 0)
    throw CellFailure{fmt::format("the output image holds {} NaN or Inf values", bad), f};
}

void FrameLoop::write_images(uint32_t f) {
  io::Image image(int(config_.width), int(config_.height), 4);
  image.pixels = rgba_;
  io::write_image(images_ / fmt::format("frame_{:04d}.exr", f), image);
  io::write_image(images_ / fmt::format("frame_{:04d}.png", f), io::display_encode(image));
  const gpu::ScenePasses& passes = renderer_.world.passes();
  const auto& outputs = renderer_.ctx.class_outputs();
  const bool own_output = std::any_of(outputs.begin(), outputs.end(), [&](const auto& output) {
    return own_class_ && output.path_class == *own_class_;
  });
  if (own_class_ && *own_class_ != trace::PathClass::direct && passes.indirect_estimate() &&
      !own_output)
    write_class_estimate(renderer_.device, passes, images_ / class_image_name(f, *own_class_));
  // The classes handed back through ctx.class_output, each scored as it was written.
  std::vector<float> rgba;
  for (const FrameContext::ClassOutput& output : outputs) {
    renderer_.device.read_image(*output.image, rgba);
    write_class_image(rgba, output.image->extent(),
                      images_ / class_image_name(f, output.path_class));
  }
}

std::vector<trace::PathClass> FrameLoop::class_outputs() const {
  std::vector<trace::PathClass> classes;
  for (const FrameContext::ClassOutput& output : renderer_.ctx.class_outputs())
    classes.push_back(output.path_class);
  return classes;
}

}  // namespace pb::run
