// tiled technique, end to end through `photonbench run` (with Vulkan validation): on cornell-box it
// completes, adds indirect light on top of the direct light (brighter, finite, and about as much as
// the path-traced indirect reference says), reports its counters, and an undersized list capacity
// is reported as an overflow warning instead of corrupting memory or failing the cell.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "io/image.h"
#include "run_fixture.h"

namespace fs = std::filesystem;

namespace {

using namespace pb::testing;

fs::path work_dir(const std::string& name) { return pb::testing::work_dir("tiled_test", name); }

double mean_rgb(const pb::io::Image& image, bool* finite) {
  *finite = all_finite(image);
  return pb::testing::mean_rgb(image);
}

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

  for (const char* frame : {"frame_0001.exr", "frame_0002.exr"}) {
    bool direct_finite = false, tiled_finite = false;
    double d = mean_rgb(pb::io::read_image(direct / "images" / frame), &direct_finite);
    double t = mean_rgb(pb::io::read_image(tiled / "images" / frame), &tiled_finite);
    EXPECT_TRUE(tiled_finite && direct_finite);
    // The Cornell box's indirect light is a sizeable share of what the camera sees (coloured walls,
    // a white ceiling lit only indirectly): the photon estimate must add a good part of it.
    EXPECT_GT(t, d * 1.1) << frame << ": tiled " << t << " vs direct " << d;
    // and not an implausible amount (a wrong kernel normalisation by pi or r would show here).
    EXPECT_LT(t, d * 3.0) << frame << ": tiled " << t << " vs direct " << d;
  }
  // What tiled adds to direct is its estimate of the `indirect` class: its mean must match the path
  // traced indirect reference (the harness's cache, class "indirect") up to the estimator's bias.
  for (const auto& entry : fs::directory_iterator(dir / "refs")) {
    if (entry.path().extension() != ".json") continue;
    auto meta = read_json(entry.path());
    if (meta["class"] != "indirect" || meta["frame"] != 1) continue;
    fs::path exr = entry.path();
    exr.replace_extension(".exr");
    bool finite = false;
    double reference = mean_rgb(pb::io::read_image(exr), &finite);
    double d = mean_rgb(pb::io::read_image(direct / "images" / "frame_0001.exr"), &finite);
    double t = mean_rgb(pb::io::read_image(tiled / "images" / "frame_0001.exr"), &finite);
    EXPECT_NEAR((t - d) / reference, 1.0, 0.15)
        << "tiled - direct " << t - d << ", reference " << reference;
    found_reference = true;
  }
  EXPECT_TRUE(found_reference);
  auto sums = counters(tiled);
  EXPECT_GT(sums["photons_stored"], 0);
  EXPECT_GT(sums["list_entries"], 0);
  EXPECT_GT(sums["photons_read"], 0);
  EXPECT_LE(sums["photons_rejected"], sums["photons_read"]);
  EXPECT_EQ(sums["overflows"], 0);
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
    bool finite = false;
    means.push_back(
        mean_rgb(pb::io::read_image(entry.path() / "images" / "frame_0000.exr"), &finite));
    auto sums = counters(entry.path());
    EXPECT_GT(sums["photons_read"], sums["photons_rejected"]);
  }
  ASSERT_EQ(means.size(), 2u);
  EXPECT_NEAR(means[0] / means[1], 1.0, 0.03) << means[0] << " vs " << means[1];
  fs::remove_all(dir);
}

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
  EXPECT_GT(sums["overflows"], 0);
  EXPECT_LE(sums["list_entries"], 2 * 16);
  std::string warnings = record["warnings"].dump();
  EXPECT_NE(warnings.find("overflowed"), std::string::npos) << warnings;
  fs::remove_all(dir);
}

}  // namespace
