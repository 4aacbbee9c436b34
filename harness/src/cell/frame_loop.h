// The frames of a cell: the warm-up frames, then the measured ones (config::FrameSettings: frames
// start - warmup .. start + count - 1). Each frame is one timed region
// (scene-update, the technique's passes, submission and the fence); after it, outside the timing,
// its rows are logged, its output is checked (validation errors, NaN or Inf) and, at metric frames,
// read back and written as images for scoring, with the estimate of the technique's own class and
// each class image it handed back (Context::class_output); with `video:` every chosen frame's
// output is written too (cell/video_capture.h).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <vector>

#include "cell/cell_record.h"
#include "cell/frame_context.h"
#include "cell/frame_log.h"
#include "config/config.h"
#include "photonbench/plugin.h"
#include "reference/reference.h"

namespace pb::run {

// What a cell renders with, built in dependency order: the device, its command buffers, the pass
// profiler, the scene side and the technique's context over all of them. On a device whose
// timestamps miss raster work (lavapipe) every pass is timed with fences (profiler.h).
struct Renderer {
  Renderer(const gpu::Device::Options& options, scene::Scene scene, uint32_t width,
           uint32_t height);
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  gpu::Device device;
  FrameCommands commands;
  Profiler profiler;
  World world;
  FrameContext ctx;
};

class FrameLoop {
 public:
  // `technique_gpu_bytes_from`: the device's allocation before the technique was made; what is
  // allocated beyond it is the technique's. `own_class`: the technique's path class, whose
  // estimate alone is written beside each metric frame when it is not the whole output.
  FrameLoop(const config::Config& config, Renderer& renderer, FrameLog& log, CellRecord& record,
            const std::filesystem::path& cell_dir, std::optional<trace::PathClass> own_class,
            uint64_t technique_gpu_bytes_from);

  // Renders every frame, printing "@frame <done> <total>" after each for the parent (counts of
  // frames played, not frame numbers). Returns the
  // metric frames written (images/frame_NNNN.exr). Throws CellFailure naming the frame.
  std::vector<uint32_t> run(Technique& technique);
  // The path classes the technique handed back images of (Context::class_output), each written
  // beside every metric frame (class_image_name) and scored against its reference.
  std::vector<trace::PathClass> class_outputs() const;

 private:
  FrameTiming render_timed(Technique& technique, uint32_t frame, bool warmup);
  void check_output(uint32_t frame);
  void write_images(uint32_t frame);

  const config::Config& config_;
  Renderer& renderer_;
  FrameLog& log_;
  CellRecord& record_;
  std::filesystem::path images_;
  std::filesystem::path video_;  // config `video:`: the captured frames (cell/video_capture.h)
  std::optional<trace::PathClass> own_class_;
  uint64_t technique_gpu_bytes_from_;
  std::vector<float> rgba_;  // the output read back after each frame
};

}  // namespace pb::run
