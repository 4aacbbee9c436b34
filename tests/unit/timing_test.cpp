// Pass timing must measure what a pass costs, raster passes included. docs/architecture.md warns
// that lavapipe bins rasterisation and may run it after the timestamp that should close the pass.
// These tests record many G-buffer (raster) or direct-light (shadow raster + compute) passes and
// compare the sum of the passes' GPU times with the fenced wall time of the whole submission.
// Agreement, not speed, is asserted: the ratio does not depend on how fast the machine is.
#include <gtest/gtest.h>

#include <chrono>

#include "cell/profiler.h"
#include "command_stream.h"
#include "gpu/shared_passes.h"
#include "scene/scene.h"

namespace pb {
namespace timing_test {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

struct Measured {
  double passes_ms = 0, wall_ms = 0;
  bool device_says_unreliable = false;
};

// Records `repeats` passes; with `fenced`, the profiler submits at every pass boundary (the
// runner's fallback). wall_ms is from the first submission to the last fence.
Measured measure(bool gbuffer, int repeats, bool fenced) {
  scene::Scene scene = scene::load_scene(std::string(PB_SOURCE_DIR) + "/scenes/pillars.yaml");
  gpu::Device device({"", false});
  testing::CommandStream commands(device);
  auto begin = [&] { commands.begin(); };
  auto submit = [&] { commands.submit(); };
  auto cmd = [&] { return commands.cmd(); };
  run::Profiler profiler(device, cmd);
  gpu::ScenePasses passes(device, scene, 640, 360, {}, profiler, cmd);
  passes.update(scene.at(0));
  // One untimed frame first, so first-use costs (pipeline JIT, page faults) are not measured.
  begin();
  passes.gbuffer();
  passes.direct_light();
  submit();
  profiler.begin_frame();
  Clock::time_point start;
  bool started = false;
  auto flush = [&] {
    if (!started) start = Clock::now(), started = true;
    auto t = Clock::now();
    submit();
    begin();
    return ms_since(t);
  };
  if (fenced) profiler.use_fenced_timing(flush);
  begin();
  if (!fenced) start = Clock::now(), started = true;
  for (int i = 0; i < repeats; ++i) gbuffer ? passes.gbuffer() : passes.direct_light();
  if (!fenced) start = Clock::now();  // recording is not execution: time the submission alone
  submit();
  Measured m;
  m.wall_ms = ms_since(start);
  for (const auto& s : profiler.end_frame())
    if (s.depth == 0) m.passes_ms += s.gpu_ms;
  m.device_says_unreliable = device.raster_timestamps_unreliable();
  return m;
}

void report(const char* what, const Measured& m) {
  std::printf("%s: passes %.2f ms, fenced wall %.2f ms, ratio %.3f\n", what, m.passes_ms, m.wall_ms,
              m.passes_ms / m.wall_ms);
}

TEST(Timing, ComputePassTimestampsAgreeWithFencedWallTime) {
  Measured m = measure(/*gbuffer=*/false, /*repeats=*/20, /*fenced=*/false);
  report("direct-light x20, timestamps", m);
  EXPECT_GT(m.passes_ms, 0.85 * m.wall_ms);
  EXPECT_LT(m.passes_ms, 1.001 * m.wall_ms);
}

TEST(Timing, RasterTimestampsAreTrustedOnlyWhereTheyAgree) {
  Measured m = measure(/*gbuffer=*/true, /*repeats=*/30, /*fenced=*/false);
  report("gbuffer x30, timestamps", m);
  EXPECT_LT(m.passes_ms, 1.001 * m.wall_ms);
  // Where timestamps miss raster work, the device must say so, so that the runner fences instead.
  if (m.passes_ms < 0.85 * m.wall_ms) EXPECT_TRUE(m.device_says_unreliable);
}

TEST(Timing, FencedRasterTimingAgreesWithFencedWallTime) {
  Measured m = measure(/*gbuffer=*/true, /*repeats=*/30, /*fenced=*/true);
  report("gbuffer x30, fenced", m);
  EXPECT_GT(m.passes_ms, 0.85 * m.wall_ms);
  EXPECT_LT(m.passes_ms, 1.001 * m.wall_ms);
}

}  // namespace timing_test
}  // namespace pb
