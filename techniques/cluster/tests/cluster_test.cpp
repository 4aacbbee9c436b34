// cluster technique, end to end through `photonbench run` (with Vulkan validation). Paper I's
// cluster method shades each sample with the same photons as tiled ("they end up shading view
// samples with the same list of photons: only the way those lists are computed changes", §5.3), and
// the cone and trivial optimisations are exact on diffuse scenes (§4.5, §4.6): on cornell-box and
// on pillars (depth discontinuities inside every tile) every variant must give tiled's image, and
// the list-based variants must accept exactly tiled's photons. Also: long per-sample lists are read
// whole (lavapipe's loop limit); each overflow is counted in its own unit and warned, not fatal; a
// traversal that runs out of its loop budget is counted exactly at the budget; the trivial node
// flux keeps a weak colour channel (fixed point per channel).
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "io/image.h"
#include "metrics/metrics.h"
#include "run_fixture.h"

namespace fs = std::filesystem;

namespace cluster_test {

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

std::string header(const fs::path& dir, const std::string& scene = "cornell-box") {
  return "name: cluster-test\nresolution: [96, 54]\nseed: 1\nscenes: [" + scene +
         "]\nlimits: {cell_seconds: 300}\nframes: {warmup: 0, count: 1, metrics_every: 1}\n"
         "metrics: [psnr]\nreference: {samples: 2, cache_dir: " +
         (dir / "refs").string() + "}\n";
}

double accepted(const fs::path& cell) {
  auto sums = counters(cell);
  return sums["photons_read"] - sums["photons_rejected"];
}

// Same photons (same tracer settings and seed), same estimator: tiled and every cluster variant
// (and a layout with all traversal in the leaf passes) must give one image; plain and cone accept
// the same photon-sample pairs as tiled (trivial accepts some at nodes instead).
void expect_tiled_image(const std::string& scene, const std::string& photons) {
  fs::path dir = work_dir(scene);
  std::string p = "{photons: " + photons;
  std::string yaml = header(dir, scene) +
                     "techniques:\n"
                     "  - technique: direct\n"
                     "  - {technique: tiled, params: " +
                     p + "}}\n" + "  - {technique: cluster, params: " + p +
                     ", variant: [plain, cone, trivial]}}\n" +
                     "  - {technique: cluster, params: " + p +
                     ", layout: shallow, top_levels: 0}}\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << "see " << (dir / "log.txt");
  fs::path direct = find_cell(dir, "direct"), tiled = find_cell(dir, "tiled");
  fs::path shallow = find_cell(dir, "cluster", {{"layout", "shallow"}});
  std::map<std::string, fs::path> variants;
  for (const char* v : {"plain", "cone", "trivial"})
    variants[v] = find_cell(dir, "cluster", {{"variant", v}, {"layout", "default"}});
  expect_ok(tiled);
  // The photon estimate adds a sizeable share of light (the comparison is not of two dark images).
  EXPECT_GT(mean_rgb(frame_image(tiled)), 1.05 * mean_rgb(frame_image(direct)));
  const double tiled_accepted = accepted(tiled);
  EXPECT_GT(tiled_accepted, 0);

  for (const auto& [variant, cell] : variants) {
    SCOPED_TRACE(variant);
    expect_ok(cell);
    EXPECT_LT(flip_mean(tiled, cell), 0.005);
    EXPECT_NEAR(mean_rgb(frame_image(cell)) / mean_rgb(frame_image(tiled)), 1.0, 1e-3);
    auto sums = counters(cell);
    EXPECT_EQ(sums["list_overflows"] + sums["job_overflows"] + sums["truncated_traversals"], 0);
    EXPECT_EQ(sums["list_mismatches"], 0);
    // Fig. 7's point: far fewer photons read than tiled; each read photon-sample pair the list
    // methods accept is one tiled accepts (the sphere and tangent-plane tests are the same).
    EXPECT_LT(sums["photons_read"], counters(tiled)["photons_read"]);
    if (variant != "trivial")
      EXPECT_NEAR(accepted(cell) / tiled_accepted, 1.0, 1e-6)
          << accepted(cell) << " vs " << tiled_accepted;
  }
  SCOPED_TRACE("shallow layout, top_levels 0");
  expect_ok(shallow);
  EXPECT_LT(flip_mean(tiled, shallow), 0.005);
  EXPECT_NEAR(accepted(shallow) / tiled_accepted, 1.0, 1e-6);

  auto plain_sums = counters(variants["plain"]);
  auto trivial_sums = counters(variants["trivial"]);
  // trivial: photons accepted at nodes are not listed, so fewer are read in the estimate.
  EXPECT_GT(trivial_sums["trivial_accepts"], 0);
  EXPECT_LT(trivial_sums["photons_read"], plain_sums["photons_read"]);
  fs::remove_all(dir);
}

TEST(Cluster, EveryVariantGivesTiledsImageOnCornellBox) {
  expect_tiled_image("cornell-box", "20000, radius: 0.08");
}

// pillars: thin occluders before a wall, so most screen tiles hold samples at very different
// depths (the case that separates the cluster hierarchy from tiles).
TEST(Cluster, EveryVariantGivesTiledsImageOnPillars) {
  expect_tiled_image("pillars", "40000, radius: 0.3");
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
  EXPECT_EQ(sums["list_overflows"] + sums["job_overflows"] + sums["truncated_traversals"], 0);
  EXPECT_NEAR(mean_rgb(frame_image(few)) / mean_rgb(frame_image(many)), 1.0, 0.03);
  fs::remove_all(dir);
}

// Each capacity overflows in its own counter (entries, jobs) and warns naming its parameter; the
// other counters stay zero; the count / insert disagreement hook is reported as for tiled.
TEST(Cluster, EachOverflowIsCountedInItsOwnUnitAndWarned) {
  fs::path dir = work_dir("overflow");
  std::string yaml = header(dir) +
                     "techniques:\n"
                     "  - technique: cluster\n"
                     "    params: {photons: 5000, radius: 0.08, max_list_entries: 16}\n"
                     "  - technique: cluster\n"
                     "    params: {photons: 5000, radius: 0.08, max_jobs: 16}\n"
                     "  - technique: cluster\n"
                     "    params: {photons: 5000, radius: 0.08, debug_insert_radius: 2}\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << "see " << (dir / "log.txt");
  fs::path lists = find_cell(dir, "cluster", {{"max_list_entries", "16"}});
  fs::path jobs = find_cell(dir, "cluster", {{"max_jobs", "16"}});
  fs::path mismatch = find_cell(dir, "cluster", {{"debug_insert_radius", "2"}});
  for (const fs::path& cell : {lists, jobs, mismatch}) expect_ok(cell);
  auto l = counters(lists), j = counters(jobs), m = counters(mismatch);
  EXPECT_GT(l["list_overflows"], 0);
  EXPECT_EQ(l["job_overflows"] + l["truncated_traversals"] + l["list_mismatches"], 0);
  EXPECT_NE(warnings(lists).find("max_list_entries"), std::string::npos) << warnings(lists);
  EXPECT_GT(j["job_overflows"], 0);
  EXPECT_EQ(j["list_overflows"] + j["truncated_traversals"] + j["list_mismatches"], 0);
  EXPECT_NE(warnings(jobs).find("max_jobs"), std::string::npos) << warnings(jobs);
  EXPECT_GT(m["list_mismatches"], 0);
  EXPECT_EQ(m["list_overflows"] + m["job_overflows"] + m["truncated_traversals"], 0);
  EXPECT_NE(warnings(mismatch).find("disagree"), std::string::npos) << warnings(mismatch);
  fs::remove_all(dir);
}

// One photon, profiled: the most loop steps an invocation took is M. With loop_budget = M nothing
// is truncated (a walk that ends with no budget left is complete: it used to be reported
// truncated); with M - 1 some traversal is, counted and warned about.
TEST(Cluster, TraversalsAreTruncatedExactlyPastTheBudget) {
  fs::path dir = work_dir("budget");
  expect_budget_boundary(dir, header(dir), "cluster",
                         "photons: 1, radius: 0.6, max_bounces: 2, variant: trivial");
  fs::remove_all(dir);
}

// The light's green is 1e-5 of its red and every surface is the same grey, so every photon and
// every pixel of an exact estimate has green / red = 1e-5. The trivial variant's node flux is fixed
// point: per-channel scales keep the ratio (the old scale, set by the total red flux, gave each
// photon 1e-5 x 2^31 / 1e5 = 0.2 units of green, rounded to 0 -- the same loss as a channel at 1e-3
// at Paper I's 1e7 photons).
TEST(Cluster, TrivialNodeFluxKeepsAWeakChannel) {
  fs::path dir = work_dir("weak");
  fs::path scene = grey_box_scene(dir, "grey-box", "[1, 1e-5, 1]");
  std::string yaml =
      header(dir, scene.string()) +
      "techniques:\n"
      "  - {technique: tiled, params: {photons: 80000, radius: 0.1}}\n"
      "  - {technique: cluster, params: {photons: 80000, radius: 0.1, variant: trivial}}\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << "see " << (dir / "log.txt");
  fs::path tiled = find_cell(dir, "tiled"), trivial = find_cell(dir, "cluster");
  expect_ok(trivial);
  ASSERT_GT(counters(trivial)["trivial_accepts"], 0);
  ASSERT_GT(counters(trivial)["photons_stored"], 100000);
  for (const fs::path& cell : {tiled, trivial}) expect_green_ratio(cell);
  fs::remove_all(dir);
}

}  // namespace cluster_test
