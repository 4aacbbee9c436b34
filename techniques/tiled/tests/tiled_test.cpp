// tiled technique, end to end through `photonbench run` (with Vulkan validation): on cornell-box it
// adds indirect light on top of the direct light (about as much as the path-traced indirect
// reference says), reads long tile lists whole (llvmpipe's loop limit), reports an undersized list
// capacity as an overflow without reading past what was written, and reports a disagreement of its
// count and insert runs (the list consistency check) instead of reading another tile's entries.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "io/image.h"
#include "run_fixture.h"

namespace fs = std::filesystem;

namespace tiled_test {

using namespace pb::testing;

fs::path work_dir(const std::string& name) { return pb::testing::work_dir("tiled_test", name); }

const char* kHeader = R"(name: tiled-test
resolution: [96, 54]
seed: 1
scenes: [cornell-box]
limits: {cell_seconds: 300}
)";

TEST(Tiled, CornellBoxAddsIndirectLightOnTopOfDirect) {
  fs::path dir = work_dir("cornell");
  std::string yaml =
      std::string(kHeader) + "frames: {warmup: 1, count: 2, metrics_every: 1}\n" +
      "metrics: [psnr]\nreference: {samples: 16, cache_dir: " + (dir / "refs").string() +
      "}\n"
      "techniques:\n"
      "  - technique: direct\n"
      "  - technique: tiled\n"
      "    params: {photons: 20000, radius: 0.05, max_bounces: 12}\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << "see " << (dir / "log.txt");
  fs::path direct = cell_dir(dir, "cornell-box__direct__");
  fs::path tiled = cell_dir(dir, "cornell-box__tiled__");
  ASSERT_FALSE(tiled.empty());
  auto record = read_json(tiled / "cell.json");
  EXPECT_EQ(record["status"], "ok") << record.dump();
  EXPECT_EQ(record["validation"], true);
  bool found_reference = false;

  for (int frame : {1, 2}) {
    auto d = frame_image(direct, frame), t = frame_image(tiled, frame);
    EXPECT_TRUE(all_finite(t) && all_finite(d));
    // The Cornell box's indirect light is a sizeable share of what the camera sees (coloured walls,
    // a white ceiling lit only indirectly): the photon estimate must add a good part of it.
    EXPECT_GT(mean_rgb(t), mean_rgb(d) * 1.1) << "frame " << frame;
    EXPECT_LT(mean_rgb(t), mean_rgb(d) * 3.0) << "frame " << frame;
  }
  // What tiled adds to direct is its estimate of the `indirect` class: its mean must match the path
  // traced indirect reference (the harness's cache, class "indirect") up to the estimator's bias.
  for (const auto& entry : fs::directory_iterator(dir / "refs")) {
    if (entry.path().extension() != ".json") continue;
    auto meta = read_json(entry.path());
    if (meta["class"] != "indirect" || meta["frame"] != 1) continue;
    fs::path exr = entry.path();
    exr.replace_extension(".exr");
    double reference = mean_rgb(pb::io::read_image(exr));
    double d = mean_rgb(frame_image(direct, 1)), t = mean_rgb(frame_image(tiled, 1));
    EXPECT_NEAR((t - d) / reference, 1.0, 0.15)
        << "tiled - direct " << t - d << ", reference " << reference;
    found_reference = true;
  }
  EXPECT_TRUE(found_reference);
  auto sums = counters(tiled);
  EXPECT_GT(sums["photons_stored"], 0);
  // Some of the photons read contribute (a wrong tangent-plane or distance test rejects them all).
  EXPECT_GT(sums["photons_read"], sums["photons_rejected"]);
  EXPECT_EQ(sums["list_overflows"], 0);
  EXPECT_EQ(sums["list_mismatches"], 0);
  // 96x54 pixels in 32-pixel tiles: 3 x 2 tiles, two view depths (floats) each, in each of the two
  // measured frames.
  EXPECT_EQ(sums["bytes_tile_bounds"], 2 * 6 * 8);
  EXPECT_EQ(record["warnings"].size(), 0u) << record["warnings"].dump();
  fs::remove_all(dir);
}

// The estimate must not depend on the photon count beyond noise: a tile list far longer than 65535
// entries (llvmpipe ends an invocation's loops after 65535 iterations in all) must be read whole.
TEST(Tiled, LongTileListsAreReadWhole) {
  fs::path dir = work_dir("long");
  std::string yaml =
      std::string(kHeader) + "frames: {warmup: 0, count: 1, metrics_every: 1}\n" +
      "metrics: [psnr]\nreference: {samples: 2, cache_dir: " + (dir / "refs").string() +
      "}\n"
      "techniques:\n"
      "  - technique: tiled\n"
      "    params: {photons: [30000, 120000], radius: 0.05, tile_size: 256}\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << "see " << (dir / "log.txt");
  std::vector<double> means;
  for (const auto& entry : fs::directory_iterator(dir / "run" / "cells")) {
    means.push_back(mean_rgb(frame_image(entry.path())));
    auto sums = counters(entry.path());
    EXPECT_GT(sums["photons_read"], sums["photons_rejected"]);
  }
  ASSERT_EQ(means.size(), 2u);
  EXPECT_NEAR(means[0] / means[1], 1.0, 0.03) << means[0] << " vs " << means[1];
  fs::remove_all(dir);
}

// An undersized capacity: entries past it are dropped, counted and warned about, the cell
// succeeds, and the estimate reads no more than was written: 16 entries per frame, each read by at
// most the 32 x 32 pixels of its tile.
TEST(Tiled, ListOverflowIsCountedAndWarnedNotFatal) {
  fs::path dir = work_dir("overflow");
  std::string yaml = std::string(kHeader) + "frames: {warmup: 0, count: 2, metrics_every: 0}\n" +
                     "techniques:\n"
                     "  - technique: tiled\n"
                     "    params: {photons: 5000, radius: 0.08, max_list_entries: 16}\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << "see " << (dir / "log.txt");
  fs::path tiled = cell_dir(dir, "cornell-box__tiled__");
  ASSERT_FALSE(tiled.empty());
  auto record = read_json(tiled / "cell.json");
  EXPECT_EQ(record["status"], "ok") << record.dump();
  auto sums = counters(tiled);
  EXPECT_GT(sums["list_overflows"], 0);
  EXPECT_GT(sums["photons_read"], 0);
  EXPECT_LE(sums["photons_read"], 2 * 16 * 32 * 32);
  EXPECT_NE(warnings(tiled).find("overflowed"), std::string::npos) << warnings(tiled);
  fs::remove_all(dir);
}

// The count and insert runs made to disagree (the debug_insert_radius test hook: the insert run
// tests larger, or smaller, spheres): the check pass counts the tiles whose lists differ from their
// counts and the technique warns; the cell still succeeds with a finite image, and (validation on)
// no insert writes outside the lists.
TEST(Tiled, CountInsertDisagreementIsCountedAndWarned) {
  fs::path dir = work_dir("mismatch");
  std::string yaml =
      std::string(kHeader) + "frames: {warmup: 0, count: 1, metrics_every: 1}\n" +
      "metrics: [psnr]\nreference: {samples: 2, cache_dir: " + (dir / "refs").string() +
      "}\n"
      "techniques:\n"
      "  - technique: tiled\n"
      "    params: {photons: 5000, radius: 0.08, debug_insert_radius: [0.5, 1.0, 2.0]}\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << "see " << (dir / "log.txt");
  for (const char* scale : {"0.5", "1", "2"}) {
    SCOPED_TRACE(scale);
    fs::path cell = find_cell(dir, "tiled", {{"debug_insert_radius", scale}});
    ASSERT_FALSE(cell.empty());
    auto record = read_json(cell / "cell.json");
    EXPECT_EQ(record["status"], "ok") << record.dump();
    EXPECT_EQ(record["validation"], true);
    EXPECT_TRUE(all_finite(frame_image(cell)));
    auto sums = counters(cell);
    bool agree = std::string(scale) == "1";
    EXPECT_EQ(sums["list_mismatches"] == 0, agree) << sums["list_mismatches"];
    EXPECT_EQ(warnings(cell).find("disagree") == std::string::npos, agree) << warnings(cell);
  }
  fs::remove_all(dir);
}

}  // namespace tiled_test
