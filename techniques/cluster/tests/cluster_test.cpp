// cluster technique, end to end through `photonbench run` (with Vulkan validation). Paper I's
// cluster method shades each sample with the same photons as tiled ("they end up shading view
// samples with the same list of photons: only the way those lists are computed changes", §5.3), and
// the cone and trivial optimisations are exact on diffuse scenes (§4.5, §4.6): on cornell-box and
// on pillars (depth discontinuities inside every tile) every variant must give tiled's image, and
// the list-based variants must accept exactly tiled's photons. Its splatter in-process
// (pb::toolkit::ClusterSplat on a synthetic frame, with validation): long per-sample lists are
// read whole (lavapipe's loop limit); each overflow is counted in its own unit and warned, not
// fatal; a traversal that runs out of its loop budget is counted exactly at the budget; the trivial
// node flux keeps a weak colour channel (fixed point per channel).
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "io/image.h"
#include "metrics/metrics.h"
#include "photonbench/toolkit/cluster_splat.h"
#include "photonbench/toolkit/tiled_splat.h"
#include "run_fixture.h"
#include "splat_bench.h"

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
  EXPECT_EQ(record["validation"], validation_on());
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

// ---- The splatter in-process (tests/support/splat_bench.h)

// A sample's lists (leaf and ancestors) far longer than 65535 entries together (llvmpipe ends an
// invocation's loops after 65535 iterations in all) must be read whole: the image must not depend
// on the photon count beyond noise. A 48x27 frame (the lists' length, not the pixel count, is what
// is tested) and a radius that reaches most of the floor in view.
TEST(ClusterSplat, LongListsAreReadWhole) {
  constexpr uint32_t kWidth = 48, kHeight = 27;
  SplatBench bench(kWidth, kHeight);
  std::vector<double> means;
  for (uint32_t photons : {30000u, 120000u}) {
    pb::toolkit::ClusterSplat splatter;
    auto report = bench.run(
        splatter, SplatBench::params("cluster", "radius: 1.5, max_list_entries: 30000000"),
        bench.photons(photons, 1.0f));
    EXPECT_EQ(report.counter("list_overflows") + report.counter("job_overflows") +
                  report.counter("truncated_traversals"),
              0);
    // More than 65535 entries read per sample on average: some samples' lists exceed the limit.
    if (photons == 120000u)
      EXPECT_GT(report.counter("photons_read") / double(kWidth * kHeight), 65535.0);
    means.push_back(mean_rgb(report.indirect));
  }
  EXPECT_GT(means[1], 0);
  EXPECT_NEAR(means[0] / means[1], 1.0, 0.03) << means[0] << " vs " << means[1];
  EXPECT_EQ(bench.validation_errors(), 0u) << bench.first_validation_error();
}

// Each capacity overflows in its own counter (entries, jobs) and warns naming its parameter; the
// other counters stay zero; the count / insert disagreement hook is reported as for tiled.
TEST(ClusterSplat, EachOverflowIsCountedInItsOwnUnitAndWarned) {
  SplatBench bench(96, 54);
  const auto photons = bench.photons(5000, 1.0f);
  auto run = [&](const std::string& params) {
    pb::toolkit::ClusterSplat splatter;
    return bench.run(splatter, SplatBench::params("cluster", "radius: 0.08, " + params), photons);
  };
  const auto l = run("max_list_entries: 16"), j = run("max_jobs: 16"),
             m = run("debug_insert_radius: 2");
  EXPECT_GT(l.counter("list_overflows"), 0);
  EXPECT_EQ(
      l.counter("job_overflows") + l.counter("truncated_traversals") + l.counter("list_mismatches"),
      0);
  EXPECT_TRUE(l.warned("max_list_entries"));
  EXPECT_GT(j.counter("job_overflows"), 0);
  EXPECT_EQ(j.counter("list_overflows") + j.counter("truncated_traversals") +
                j.counter("list_mismatches"),
            0);
  EXPECT_TRUE(j.warned("max_jobs"));
  EXPECT_GT(m.counter("list_mismatches"), 0);
  EXPECT_EQ(
      m.counter("list_overflows") + m.counter("job_overflows") + m.counter("truncated_traversals"),
      0);
  EXPECT_TRUE(m.warned("disagree"));
  EXPECT_EQ(bench.validation_errors(), 0u) << bench.first_validation_error();
}

// One photon, profiled: the most loop steps an invocation took is M. With loop_budget = M nothing
// is truncated (a walk that ends with no budget left is complete: it used to be reported
// truncated); with M - 1 some traversal is, counted and warned about.
TEST(ClusterSplat, TraversalsAreTruncatedExactlyPastTheBudget) {
  SplatBench bench(96, 54);
  expect_budget_boundary(budget_boundary<pb::toolkit::ClusterSplat>(
      bench, "cluster", "radius: 0.6, variant: trivial"));
  EXPECT_EQ(bench.validation_errors(), 0u) << bench.first_validation_error();
}

// The light's green is 1e-5 of its red and the floor is grey, so every photon and every pixel of
// an exact estimate has green / red = 1e-5. The trivial variant's node flux is fixed point:
// per-channel scales keep the ratio (the old scale, set by the total red flux, gave each photon
// 1e-5 x 2^31 / 1e5 = 0.2 units of green, rounded to 0 -- the same loss as a channel at 1e-3 at
// Paper I's 1e7 photons).
TEST(ClusterSplat, TrivialNodeFluxKeepsAWeakChannel) {
  SplatBench bench(96, 54);
  const auto photons = bench.photons(120000, 1.0f, 7, glm::vec3(1, 1e-5f, 1));
  pb::toolkit::TiledSplat tiled;
  expect_green_ratio(bench.run(tiled, SplatBench::params("tiled", "radius: 0.3"), photons).indirect,
                     "tiled");
  pb::toolkit::ClusterSplat trivial;
  auto report =
      bench.run(trivial, SplatBench::params("cluster", "radius: 0.3, variant: trivial"), photons);
  ASSERT_GT(report.counter("trivial_accepts"), 0);
  expect_green_ratio(report.indirect, "cluster trivial");
  EXPECT_EQ(bench.validation_errors(), 0u) << bench.first_validation_error();
}

}  // namespace cluster_test
