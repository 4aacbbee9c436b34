// tiled technique: end to end through `photonbench run` (with Vulkan validation), on cornell-box it
// adds indirect light on top of the direct light (about as much as the path-traced indirect
// reference says); its splatter in-process (pb::toolkit::TiledSplat on a synthetic frame, with
// validation) reads long tile lists whole (llvmpipe's loop limit), reports an undersized list
// capacity as an overflow without reading past what was written, and reports a disagreement of its
// count and insert runs (the list consistency check) instead of reading another tile's entries.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "io/image.h"
#include "photonbench/toolkit/tiled_splat.h"
#include "run_fixture.h"
#include "splat_bench.h"

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
  EXPECT_EQ(record["validation"], validation_on());
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

// ---- The splatter in-process (tests/support/splat_bench.h)

// The estimate must not depend on the photon count beyond noise: a tile list far longer than 65535
// entries (llvmpipe ends an invocation's loops after 65535 iterations in all) must be read whole.
// One 256-pixel tile holds the whole 48x27 frame, so its list holds every photon.
TEST(TiledSplat, LongTileListsAreReadWhole) {
  SplatBench bench(48, 27);
  std::vector<double> means;
  for (uint32_t photons : {30000u, 120000u}) {
    pb::toolkit::TiledSplat splatter;
    auto report = bench.run(splatter, SplatBench::params("tiled", "radius: 0.05, tile_size: 256"),
                            bench.photons(photons, 1.0f));
    EXPECT_GT(report.counter("photons_read"), report.counter("photons_rejected"));
    means.push_back(mean_rgb(report.indirect));
  }
  EXPECT_GT(means[1], 0);
  EXPECT_NEAR(means[0] / means[1], 1.0, 0.03) << means[0] << " vs " << means[1];
  EXPECT_EQ(bench.validation_errors(), 0u) << bench.first_validation_error();
}

// An undersized capacity: entries past it are dropped, counted and warned about, nothing throws,
// and the estimate reads no more than was written: 16 entries per frame, each read by at most the
// 32 x 32 pixels of its tile.
TEST(TiledSplat, ListOverflowIsCountedAndWarnedNotFatal) {
  SplatBench bench(96, 54);
  pb::toolkit::TiledSplat splatter;
  auto report =
      bench.run(splatter, SplatBench::params("tiled", "radius: 0.08, max_list_entries: 16"),
                bench.photons(5000, 1.0f), /* frames */ 2);
  EXPECT_GT(report.counter("list_overflows"), 0);
  EXPECT_GT(report.counter("photons_read"), 0);
  EXPECT_LE(report.counter("photons_read"), 2 * 16 * 32 * 32);
  EXPECT_TRUE(report.warned("overflowed"));
  EXPECT_EQ(bench.validation_errors(), 0u) << bench.first_validation_error();
}

// The count and insert runs made to disagree (the debug_insert_radius test hook: the insert run
// tests larger, or smaller, spheres): the check pass counts the tiles whose lists differ from their
// counts and the splatter warns; the image stays finite, and (validation on) no insert writes
// outside the lists.
TEST(TiledSplat, CountInsertDisagreementIsCountedAndWarned) {
  SplatBench bench(96, 54);
  const auto photons = bench.photons(5000, 1.0f);
  for (const char* scale : {"0.5", "1", "2"}) {
    SCOPED_TRACE(scale);
    pb::toolkit::TiledSplat splatter;
    auto report = bench.run(
        splatter,
        SplatBench::params("tiled", std::string("radius: 0.08, debug_insert_radius: ") + scale),
        photons);
    EXPECT_TRUE(all_finite(report.indirect));
    const bool agree = std::string(scale) == "1";
    EXPECT_EQ(report.counter("list_mismatches") == 0, agree) << report.counter("list_mismatches");
    EXPECT_EQ(report.warned("disagree"), !agree);
  }
  EXPECT_EQ(bench.validation_errors(), 0u) << bench.first_validation_error();
}

}  // namespace tiled_test
