// cluster technique, end to end through `photonbench run` (with Vulkan validation). Paper I's
// cluster method shades each sample with the same photons as tiled ("they end up shading view
// samples with the same list of photons: only the way those lists are computed changes", §5.3), and
// the cone and trivial optimisations are exact on diffuse scenes (§4.5, §4.6): on cornell-box (all
// diffuse) every variant must give tiled's image up to float summation order. Also: long per-sample
// lists are read whole (lavapipe's loop limit), and undersized capacities are warned, not fatal.
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
#include "metrics/metrics.h"
#include "run_fixture.h"

namespace fs = std::filesystem;

namespace {

using namespace pb::testing;

fs::path work_dir(const std::string& name) { return pb::testing::work_dir("cluster_test", name); }

double flip_mean(const fs::path& reference_cell, const fs::path& test_cell) {
  return pb::metrics::flip(frame_image(reference_cell), frame_image(test_cell)).stats.mean;
}

void expect_ok(const fs::path& cell) {
  ASSERT_FALSE(cell.empty());
  auto record = read_json(cell / "cell.json");
  EXPECT_EQ(record["status"], "ok") << record.dump();
  EXPECT_EQ(record["validation"], true);
}

std::string header(const fs::path& dir) {
  return "name: cluster-test\nresolution: [96, 54]\nseed: 1\nscenes: [cornell-box]\n"
         "limits: {cell_seconds: 300}\nframes: {warmup: 0, count: 1, metrics_every: 1}\n"
         "metrics: [psnr]\nreference: {samples: 2, cache_dir: " +
         (dir / "refs").string() + "}\n";
}

// Same photons (same tracer settings and seed), same estimator: tiled and every cluster variant
// (and a second layout with all traversal in the leaf passes) must give one image.
TEST(Cluster, EveryVariantGivesTiledsImageOnCornellBox) {
  fs::path dir = work_dir("variants");
  std::string yaml = header(dir) +
                     "techniques:\n"
                     "  - technique: direct\n"
                     "  - technique: tiled\n"
                     "    params: {photons: 20000, radius: 0.08}\n"
                     "  - technique: cluster\n"
                     "    params: {photons: 20000, radius: 0.08, variant: [plain, cone, trivial]}\n"
                     "  - technique: cluster\n"
                     "    params: {photons: 20000, radius: 0.08, layout: shallow, top_levels: 0}\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << "see " << (dir / "log.txt");
  fs::path direct = find_cell(dir, "direct"), tiled = find_cell(dir, "tiled");
  fs::path shallow = find_cell(dir, "cluster", {{"layout", "shallow"}});
  std::map<std::string, fs::path> variants;
  for (const char* v : {"plain", "cone", "trivial"})
    variants[v] = find_cell(dir, "cluster", {{"variant", v}, {"layout", "default"}});
  expect_ok(tiled);
  // The photon estimate adds a sizeable share of light (the comparison below is not of two dark
  // images).
  EXPECT_GT(mean_rgb(frame_image(tiled)), 1.1 * mean_rgb(frame_image(direct)));

  for (const auto& [variant, cell] : variants) {
    SCOPED_TRACE(variant);
    expect_ok(cell);
    EXPECT_LT(flip_mean(tiled, cell), 0.005);
    EXPECT_NEAR(mean_rgb(frame_image(cell)) / mean_rgb(frame_image(tiled)), 1.0, 1e-3);
    auto sums = counters(cell);
    EXPECT_GT(sums["list_entries"], 0);
    EXPECT_GT(sums["jobs"], 0);
    EXPECT_GT(sums["hierarchy_leaves"], 0);
    EXPECT_LE(sums["photons_rejected"], sums["photons_read"]);
    EXPECT_EQ(sums["overflows"], 0);
    EXPECT_GT(sums["bytes_cluster_hierarchy"], 0);
  }
  SCOPED_TRACE("shallow layout, top_levels 0");
  expect_ok(shallow);
  EXPECT_LT(flip_mean(tiled, shallow), 0.005);

  auto plain_sums = counters(variants["plain"]);
  auto cone_sums = counters(variants["cone"]);
  auto trivial_sums = counters(variants["trivial"]);
  // The hierarchy's point (Paper I Fig. 7): far fewer photons read than tiled.
  EXPECT_LT(plain_sums["photons_read"], counters(tiled)["photons_read"]);
  // cone: something is rejected by the normal cones, and exactly (same image above).
  EXPECT_GT(cone_sums["cone_rejects"], 0);
  EXPECT_GT(cone_sums["bytes_normal_cone"], 0);
  // trivial: photons accepted at nodes are not listed, so fewer are read in the estimate.
  EXPECT_GT(trivial_sums["trivial_accepts"], 0);
  EXPECT_LT(trivial_sums["photons_read"], plain_sums["photons_read"]);
  EXPECT_GT(trivial_sums["bytes_accum_flux"], 0);
  fs::remove_all(dir);
}

// A sample's lists (leaf and ancestors) far longer than 65535 entries together (llvmpipe ends an
// invocation's loops after 65535 iterations in all) must be read whole: the image must not depend
// on the photon count beyond noise.
TEST(Cluster, LongListsAreReadWhole) {
  fs::path dir = work_dir("long");
  std::string yaml =
      header(dir) +
      "techniques:\n"
      "  - technique: cluster\n"
      "    params: {photons: [30000, 120000], radius: 1.0, max_list_entries: 30000000}\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << "see " << (dir / "log.txt");
  fs::path few = find_cell(dir, "cluster", {{"photons", "30000"}});
  fs::path many = find_cell(dir, "cluster", {{"photons", "120000"}});
  expect_ok(few);
  expect_ok(many);
  auto sums = counters(many);
  // More than 65535 entries read per sample on average: some samples' lists exceed the limit.
  EXPECT_GT(sums["photons_read"] / (96.0 * 54.0), 65535.0);
  EXPECT_EQ(sums["overflows"], 0);
  EXPECT_NEAR(mean_rgb(frame_image(few)) / mean_rgb(frame_image(many)), 1.0, 0.03);
  fs::remove_all(dir);
}

TEST(Cluster, OverflowIsCountedAndWarnedNotFatal) {
  fs::path dir = work_dir("overflow");
  std::string yaml = header(dir) +
                     "techniques:\n"
                     "  - technique: cluster\n"
                     "    params: {photons: 5000, radius: 0.08, max_list_entries: 16}\n"
                     "  - technique: cluster\n"
                     "    params: {photons: 5000, radius: 0.08, max_jobs: 16}\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << "see " << (dir / "log.txt");
  fs::path lists = find_cell(dir, "cluster", {{"max_list_entries", "16"}});
  fs::path jobs = find_cell(dir, "cluster", {{"max_jobs", "16"}});
  for (const fs::path& cell : {lists, jobs}) {
    SCOPED_TRACE(cell.string());
    expect_ok(cell);
    auto sums = counters(cell);
    EXPECT_GT(sums["overflows"], 0);
    std::string warnings = read_json(cell / "cell.json")["warnings"].dump();
    EXPECT_NE(warnings.find("overflowed"), std::string::npos) << warnings;
  }
  EXPECT_LE(counters(lists)["list_entries"], 16);
  EXPECT_NE(read_json(jobs / "cell.json")["warnings"].dump().find("max_jobs"), std::string::npos);
  fs::remove_all(dir);
}

}  // namespace
