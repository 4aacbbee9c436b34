// frames.start (config::FrameSettings): the first measured frame, its warm-up frames just before
// it, the frames a cell plays and scores, and the errors (file:line:col and key) for a start that
// leaves no room for the warm-up or runs past the last frame a run may play.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cell/scoring.h"
#include "config/config.h"
#include "photonbench/error.h"

namespace pb {
namespace frame_range_test {

config::Config load(const std::string& frames) {
  auto file = std::filesystem::path(::testing::TempDir()) /
              ("pb_frame_range_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(file) << "name: t\nscenes: [" PB_SOURCE_DIR
                         "/scenes/cornell-box.yaml]\ntechniques:\n  - technique: direct\n"
                         "frames: "
                      << frames << "\n";
  return config::load_config(file, {});
}

std::string load_error(const std::string& frames) {
  try {
    load(frames);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

using Frames = std::vector<uint32_t>;

// Without `start` the warm-up frames are the first ones, as before `start` existed.
TEST(FramesStart, DefaultsToTheWarmupFrames) {
  config::FrameSettings f = load("{warmup: 2, count: 32}").frames;
  EXPECT_EQ(f.start, 2u);
  EXPECT_EQ(f.first_frame(), 0u);
  EXPECT_EQ(f.last_frame(), 33u);
  EXPECT_FALSE(f.measured(1));
  EXPECT_TRUE(f.measured(2));
  config::FrameSettings defaults = load("{}").frames;
  EXPECT_EQ(defaults.start, config::FrameSettings{}.warmup);
  EXPECT_EQ(defaults.first_frame(), 0u);
}

// Measuring frames 298.. takes its 4 warm-up frames 294..297, not 298 of them; the scored frames
// count from start.
TEST(FramesStart, WarmsUpJustBeforeTheFirstMeasuredFrame) {
  config::Config c = load("{warmup: 4, start: 298, count: 9, metrics_every: 4}");
  EXPECT_EQ(c.frames.first_frame(), 294u);
  EXPECT_EQ(c.frames.last_frame(), 306u);
  EXPECT_FALSE(c.frames.measured(297));
  EXPECT_TRUE(c.frames.measured(298));
  EXPECT_EQ(run::metric_frames(c), (Frames{298, 302, 306}));
  config::Config no_warmup = load("{warmup: 0, start: 10, count: 2, metrics_every: 1}");
  EXPECT_EQ(no_warmup.frames.first_frame(), 10u);
  EXPECT_EQ(run::metric_frames(no_warmup), (Frames{10, 11}));
}

TEST(FramesStart, ErrorsNameFileLineColumnAndKey) {
  std::string e = load_error("{warmup: 4, start: 2}");
  EXPECT_NE(e.find(".yaml:5:"), std::string::npos) << e;
  EXPECT_NE(e.find("frames.start: the first measured frame 2 leaves no room for the 4 warm-up "
                   "frames"),
            std::string::npos)
      << e;
  e = load_error("{warmup: 0, start: " + std::to_string(config::kMaxFrames - 5) + ", count: 6}");
  EXPECT_NE(e.find("frames.start: frames"), std::string::npos) << e;
  EXPECT_NE(e.find("go past the last frame a run may play"), std::string::npos) << e;
  // The last frame a run may play is fine.
  EXPECT_EQ(load("{warmup: 0, start: " + std::to_string(config::kMaxFrames - 5) + ", count: 5}")
                .frames.last_frame(),
            config::kMaxFrames - 1);
  e = load_error("{start: -1}");
  EXPECT_NE(e.find("frames.start"), std::string::npos) << e;
  e = load_error("{strat: 3}");
  EXPECT_NE(e.find("frames.strat: unknown key; did you mean 'start'?"), std::string::npos) << e;
}

}  // namespace frame_range_test
}  // namespace pb
