// Config `video:`: its keys read and checked (errors at file:line:col and key), and which cells and
// frames the frame loop saves as video frames (cell/video_capture.h).
#include "cell/video_capture.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "config/config.h"
#include "photonbench/error.h"

namespace pb::run {
namespace video_capture_test {

const std::string kHead =
    "resolution: [64, 36]\n"
    "frames: {warmup: 2, count: 7}\n"
    "scenes: [cornell-box]\n"
    "techniques:\n"
    "  - technique: direct\n"
    "  - technique: tiled\n";

config::Config parse(const std::string& video) {
  return config::parse_config(kHead + video, "t.yaml", {});
}

std::string error_of(const std::string& video) {
  try {
    parse(video);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(VideoConfig, IsOffWithoutTheBlockAndReadsItsKeys) {
  const config::Config plain = parse("");
  EXPECT_FALSE(plain.video.enabled);
  EXPECT_FALSE(captures_cell(plain.video, "direct"));

  const config::Config all = parse("video: {}\n");
  EXPECT_TRUE(all.video.enabled);
  EXPECT_EQ(all.video.every, 1u);
  EXPECT_TRUE(captures_cell(all.video, "direct"));
  EXPECT_TRUE(captures_cell(all.video, "tiled"));
  EXPECT_TRUE(captures_cell(parse("video: {cells: all}\n").video, "tiled"));

  const config::Config some = parse("video: {every: 3, cells: [tiled], crop: [4, 2, 40, 30]}\n");
  EXPECT_EQ(some.video.every, 3u);
  EXPECT_FALSE(captures_cell(some.video, "direct"));
  EXPECT_TRUE(captures_cell(some.video, "tiled"));
  EXPECT_EQ(video_crop(some.video, 64, 36), (std::array<uint32_t, 4>{4, 2, 40, 30}));
  // Without a crop: the centre half.
  EXPECT_EQ(video_crop(all.video, 64, 36), (std::array<uint32_t, 4>{16, 9, 32, 18}));
}

TEST(VideoConfig, ErrorsNameTheFileLineAndKey) {
  EXPECT_EQ(error_of("video: {cells: [tiled, knn]}\n"),
            "t.yaml:7:24: video.cells[1]: 'knn' is not a technique of this config's `techniques`");
  EXPECT_EQ(error_of("video: {cells: some}\n"),
            "t.yaml:7:16: video.cells: expected all, or a list of the config's technique names");
  EXPECT_EQ(error_of("video: {crop: [40, 0, 30, 10]}\n"),
            "t.yaml:7:15: video.crop: the window 30x10 at (40, 0) is not inside the 64x36 image");
  EXPECT_EQ(error_of("video: {crop: [0, 0, 10]}\n"),
            "t.yaml:7:15: video.crop: expected [x, y, w, h]");
  EXPECT_NE(error_of("video: {every: 0}\n").find("t.yaml:7:16: video.every"), std::string::npos);
  EXPECT_EQ(
      error_of("video: {evry: 2}\n"),
      "t.yaml:7:9: video.evry: unknown key; did you mean 'every'? (allowed: every, cells, crop)");
}

TEST(VideoCapture, SavesEveryNthMeasuredFrameAndNoWarmUpFrame) {
  // frames 0, 1 warm up; 2 .. 8 are measured.
  const config::Config c = parse("video: {every: 3}\n");
  std::vector<uint32_t> saved;
  for (uint32_t f = c.frames.first_frame(); f <= c.frames.last_frame(); ++f)
    if (captures_frame(c.video, c.frames, f)) saved.push_back(f);
  EXPECT_EQ(saved, (std::vector<uint32_t>{2, 5, 8}));
  const config::Config off = parse("");
  for (uint32_t f = 0; f < 9; ++f) EXPECT_FALSE(captures_frame(off.video, off.frames, f));
}

TEST(VideoCapture, WritesTheIndexTheEncoderReads) {
  const auto dir = std::filesystem::temp_directory_path() / "pb_video_capture_test";
  std::filesystem::remove_all(dir);
  const config::Config c = parse("video: {every: 2, crop: [1, 2, 3, 4]}\n");
  write_video_index(dir, 24.f, c.video, 64, 36, {2, 4, 6});
  std::ifstream in(dir / "video.json");
  const nlohmann::json index = nlohmann::json::parse(in);
  EXPECT_EQ(index["fps"].get<double>(), 24.0);
  EXPECT_EQ(index["every"].get<int>(), 2);
  EXPECT_EQ(index["crop"], nlohmann::json::array({1, 2, 3, 4}));
  EXPECT_EQ(index["frames"], nlohmann::json::array({2, 4, 6}));
  std::filesystem::remove_all(dir);
}

}  // namespace video_capture_test
}  // namespace pb::run
