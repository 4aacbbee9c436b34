// The frames a cell plays (cell/frame_loop.h), on the GPU (lavapipe): frames.start - warmup ..
// start + count - 1 in order, the warm-up frames just before frames.start and flagged so, each
// frame's state at time = frame / fps, and the metric frames counted from frames.start.
#include "cell/frame_loop.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cell/cell_record.h"
#include "cell/frame_log.h"
#include "config/config.h"
#include "plan/plan.h"
#include "scene/scene.h"

namespace pb::run {
namespace frame_loop_test {

namespace fs = std::filesystem;

// What the loop showed a technique at each frame it rendered.
struct Played {
  uint32_t index;
  bool warmup;
  float time;
};

class RecordingTechnique final : public Technique {
 public:
  void setup(Context&, const Params&) override {}
  void render(Context& ctx) override {
    played.push_back({ctx.frame().index, ctx.frame().warmup, ctx.frame().time});
  }
  std::vector<Played> played;
};

TEST(FrameLoop, PlaysTheWarmupFramesJustBeforeFramesStart) {
  const fs::path dir =
      fs::temp_directory_path() / ("pb_frame_loop_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "images");  // the cell's folder, as the runner makes it
  std::ofstream(dir / "floor.yaml")
      << "purpose: a lit floor, two frames a second\nfps: 2\nframes: 4\n"
         "camera: {position: [0, 3, 2], target: [0, 0, 0], fov_deg: 50}\n"
         "lights: [{type: point, position: [0, 2, 0], power: 40}]\n"
         "materials: {floor: {type: diffuse}}\n"
         "objects: [{shape: {type: quad, size: [4, 4]}, material: floor}]\n";
  std::ofstream(dir / "config.yaml")
      << "name: t\nresolution: [16, 16]\nscenes: [" << (dir / "floor.yaml").string()
      << "]\ntechniques: [{technique: direct}]\n"
         "frames: {warmup: 2, start: 5, count: 3, metrics_every: 2}\n";
  const config::Config config = config::load_config(dir / "config.yaml", {});
  Renderer renderer({}, scene::load_scene(dir / "floor.yaml"), config.width, config.height);
  Cell cell;
  cell.id = "floor__recording__0";
  CellRecord record(cell);
  FrameLog log(dir);
  FrameLoop loop(config, renderer, log, record, dir, std::nullopt, 0);
  RecordingTechnique technique;
  std::vector<uint32_t> written;
  try {
    written = loop.run(technique);
  } catch (const CellFailure& failure) {
    FAIL() << "frame " << failure.frame.value_or(0) << ": " << failure.reason;
  }

  ASSERT_EQ(technique.played.size(), 5u);
  const std::vector<uint32_t> frames = {3, 4, 5, 6, 7};
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(technique.played[i].index, frames[i]) << i;
    EXPECT_EQ(technique.played[i].warmup, frames[i] < 5) << frames[i];
    EXPECT_FLOAT_EQ(technique.played[i].time, frames[i] / 2.f) << frames[i];
  }
  EXPECT_EQ(written, (std::vector<uint32_t>{5, 7}));
  EXPECT_TRUE(fs::exists(dir / "images" / "frame_0005.exr"));
  EXPECT_FALSE(fs::exists(dir / "images" / "frame_0003.exr"));
  fs::remove_all(dir);
}

}  // namespace frame_loop_test
}  // namespace pb::run
