// Scoring (cell/scoring.h) with noise floors and bounce-matched references: which references a cell
// is scored against, and what one scored cell writes (metrics.csv columns and rows, cell.json
// means), checked against the metrics computed here from the cached reference entries.
#include "cell/scoring.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "cell/cell_record.h"
#include "config/config.h"
#include "io/image.h"
#include "io/results.h"
#include "metrics/flicker.h"
#include "metrics/metrics.h"
#include "metrics/noise_floor.h"
#include "photonbench/error.h"
#include "reference/reference.h"
#include "scene/scene.h"

namespace pb::run {
namespace scoring_test {

// One folder per test process: CTest runs this file's tests side by side, and one test's
// remove_all of the shared reference cache raced another's reads of it.
const std::filesystem::path kTemp =
    std::filesystem::path(::testing::TempDir()) / ("pb_scoring_test_" + std::to_string(::getpid()));

config::Config load(const std::string& reference_block,
                    const std::string& frames = "{warmup: 0, count: 1, metrics_every: 1}") {
  std::filesystem::create_directories(kTemp);
  auto file = kTemp / "config.yaml";
  std::ofstream(file) << "name: t\nresolution: [32, 18]\nframes: " << frames
                      << "\nscenes: [" PB_SOURCE_DIR
                         "/scenes/cornell-box.yaml]\ntechniques:\n  - technique: direct\n"
                      << reference_block;
  return config::load_config(file, {});
}

// Every metrics_every-th measured frame and the metrics_window - 1 after it, from the first
// measured frame, inside the measured frames, each once.
TEST(Scoring, MetricFramesAreWindowsFromEveryNthFrame) {
  using Frames = std::vector<uint32_t>;
  EXPECT_EQ(metric_frames(load("", "{warmup: 2, count: 9, metrics_every: 4}")), (Frames{2, 6, 10}));
  EXPECT_EQ(metric_frames(load("", "{warmup: 2, count: 9, metrics_every: 4, metrics_window: 2}")),
            (Frames{2, 3, 6, 7, 10}));
  EXPECT_EQ(metric_frames(load("", "{warmup: 0, count: 5, metrics_every: 2, metrics_window: 3}")),
            (Frames{0, 1, 2, 3, 4}));
  EXPECT_EQ(metric_frames(load("", "{warmup: 0, count: 5, metrics_every: 0, metrics_window: 3}")),
            Frames{});
  try {
    load("", "{count: 5, metrics_window: 0}");
    FAIL() << "metrics_window: 0 was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("frames.metrics_window"), std::string::npos) << e.what();
  }
}

// Flicker compares a frame with the frame before only: of metric frames 0, 1 and 3, frame 1
// carries it (against 0), frame 3 does not (frame 2 was not scored), and it equals
// metrics::flicker of the two frames' images and references.
TEST(Scoring, FlickerComparesConsecutiveFramesOnly) {
  const config::Config c =
      load(fmt::format("reference: {{samples: 8, cache_dir: {}}}\n", (kTemp / "cache").string()),
           "{warmup: 0, count: 4, metrics_every: 3, metrics_window: 2}");
  const std::vector<uint32_t> frames = metric_frames(c);
  ASSERT_EQ(frames, (std::vector<uint32_t>{0, 1, 3}));
  const scene::Scene scene = scene::load_scene(PB_SOURCE_DIR "/scenes/cornell-box.yaml");
  const std::filesystem::path dir = kTemp / "flicker";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "images");
  for (uint32_t f : frames) {
    io::Image output(32, 18, 4);
    for (size_t i = 0; i < output.pixels.size(); ++i)
      output.pixels[i] = i % 4 == 3 ? 1.f : 0.2f + 0.05f * float(f) + 0.01f * float(i % 7);
    io::write_image(dir / "images" / fmt::format("frame_{:04d}.exr", f), output);
  }
  score_cell(c, Cell{}, scene, frames, "combined", dir);
  const auto csv = io::read_csv(dir / "metrics.csv");
  ASSERT_EQ(csv.size(), 4u);
  const size_t flicker_column = csv[0].size() - 2;
  ASSERT_EQ(csv[0][flicker_column], "flicker");
  EXPECT_EQ(csv[1][flicker_column], "");  // frame 0: nothing before
  EXPECT_EQ(csv[3][0], "3");
  EXPECT_EQ(csv[3][flicker_column], "");  // frame 3: frame 2 was not scored
  ASSERT_EQ(csv[2][0], "1");
  trace::ReferenceCache cache(kTemp / "cache");
  // NoisyReference refers to the images: the entries stay alive here.
  const auto before = cache.get_entry(scene, scene.at(0), trace::PathClass::combined, 32, 18,
                                      reference_options(c, 0));
  const auto after = cache.get_entry(scene, scene.at(1), trace::PathClass::combined, 32, 18,
                                     reference_options(c, 0));
  ASSERT_TRUE(before && after);
  // The outputs as scored: read back from the files the cell wrote.
  const metrics::Flicker expected =
      metrics::flicker({before->mean, before->variance, before->half[0], before->half[1]},
                       {after->mean, after->variance, after->half[0], after->half[1]},
                       io::read_image(dir / "images" / "frame_0000.exr"),
                       io::read_image(dir / "images" / "frame_0001.exr"));
  EXPECT_NEAR(std::stod(csv[2][flicker_column]) / expected.value, 1.0, 1e-5);
  EXPECT_NEAR(std::stod(csv[2][flicker_column + 1]) / expected.floor, 1.0, 1e-5);
}

std::vector<std::string> names(const std::vector<ScoredReference>& refs) {
  std::vector<std::string> out;
  for (const auto& r : refs) out.push_back(r.name);
  return out;
}

TEST(Scoring, BounceMatchedReferencesOnlyWhenAskedAndForTruncatedTechniques) {
  Cell photon, plain;
  photon.params = {{"max_bounces", "4"}};
  config::Config c = load("reference: {samples: 8}\n");
  EXPECT_EQ(names(scored_references(c, photon)), std::vector<std::string>{"full"});
  c = load("reference: {samples: 8, bounce_matched: true}\n");
  const auto refs = scored_references(c, photon);
  ASSERT_EQ(names(refs), (std::vector<std::string>{"full", "bounce_matched"}));
  EXPECT_EQ(refs[0].options.max_bounces, 0u);
  EXPECT_EQ(refs[1].options.max_bounces, trace::bounces_matching_photon_technique(4));
  EXPECT_EQ(refs[1].options.samples, refs[0].options.samples);
  EXPECT_EQ(names(scored_references(c, plain)), std::vector<std::string>{"full"});
  try {
    load("reference: {samples: 8, bounce_matched: 3}\n");
    FAIL() << "bounce_matched: 3 was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("reference.bounce_matched"), std::string::npos)
        << e.what();
  }
}

// A cell is scored against references of its own scene entry's stop rules, both the full one and
// the bounce-matched one.
TEST(Scoring, ACellsReferencesFollowItsSceneEntrysStopRules) {
  config::Config c = load("reference: {rel_error: 0.1, max_seconds: 60, bounce_matched: true}\n");
  c.scenes.push_back(c.scenes[0]);
  c.scenes[1].reference = config::ReferenceStopRules{0.02, 0, 0};
  Cell shared, own;
  shared.params = own.params = {{"max_bounces", "4"}};
  own.scene_entry = 1;
  for (const ScoredReference& ref : scored_references(c, shared)) {
    EXPECT_FLOAT_EQ(ref.options.rel_error, 0.1f) << ref.name;
    EXPECT_EQ(ref.options.max_seconds, 60.0) << ref.name;
  }
  const auto refs = scored_references(c, own);
  ASSERT_EQ(refs.size(), 2u);
  for (const ScoredReference& ref : refs) {
    EXPECT_FLOAT_EQ(ref.options.rel_error, 0.02f) << ref.name;
    EXPECT_EQ(ref.options.max_seconds, 0.0) << ref.name;
  }
}

TEST(Scoring, RowsCarryFloorsAndUnbiasedErrorsAgainstBothReferences) {
  const config::Config c =
      load(fmt::format("reference: {{samples: 8, bounce_matched: true, cache_dir: {}}}\n",
                       (kTemp / "cache").string()));
  const scene::Scene scene = scene::load_scene(PB_SOURCE_DIR "/scenes/cornell-box.yaml");
  Cell cell;
  cell.params = {{"max_bounces", "4"}};
  std::filesystem::remove_all(kTemp / "cache");
  const std::filesystem::path dir = kTemp / "cell";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "images");
  // The technique's output: a flat grey, far from the reference (its scores are resolved).
  io::Image output(32, 18, 4);
  for (size_t i = 0; i < output.pixels.size(); ++i) output.pixels[i] = i % 4 == 3 ? 1.f : 0.3f;
  io::write_image(dir / "images" / "frame_0000.exr", output);

  const ScoreResult result = score_cell(c, cell, scene, {0}, "combined", dir);
  const auto csv = io::read_csv(dir / "metrics.csv");
  const std::vector<std::string> header = {
      "frame",        "path_class",   "reference",       "flip",       "ssim",         "psnr",
      "rmse",         "relmse",       "flip_floor",      "ssim_floor", "psnr_floor",   "rmse_floor",
      "relmse_floor", "mse_unbiased", "relmse_unbiased", "flicker",    "flicker_floor"};
  ASSERT_EQ(csv.size(), 3u);  // header, full, bounce_matched
  EXPECT_EQ(csv[0], header);
  const size_t first_flicker_column = header.size() - 2;

  trace::ReferenceCache cache(kTemp / "cache");
  for (const ScoredReference& ref : scored_references(c, cell)) {
    SCOPED_TRACE(ref.name);
    const auto entry =
        cache.get_entry(scene, scene.at(0), trace::PathClass::combined, 32, 18, ref.options);
    ASSERT_TRUE(entry);
    EXPECT_EQ(entry->max_bounces, ref.options.max_bounces);
    const metrics::NoisyReference noisy{entry->mean, entry->variance, entry->half[0],
                                        entry->half[1]};
    const metrics::Scores s = metrics::evaluate(entry->mean, output);
    const metrics::NoiseFloor f = metrics::noise_floor(noisy);
    const metrics::UnbiasedErrors u = metrics::unbiased_errors(noisy, output);
    const auto& row = csv[ref.name == "full" ? 1 : 2];
    std::map<std::string, double> v;
    for (size_t k = 3; k < first_flicker_column; ++k) v[header[k]] = std::stod(row[k]);
    // One metric frame: no frame pair, so no flicker.
    EXPECT_EQ(row[first_flicker_column], "");
    EXPECT_EQ(row[first_flicker_column + 1], "");
    EXPECT_EQ(row[1], "combined");
    EXPECT_EQ(row[2], ref.name);
    EXPECT_NEAR(v["flip"], s.flip.mean, 1e-5);
    EXPECT_NEAR(v["flip_floor"], f.scores.flip.mean, 1e-5);
    EXPECT_NEAR(v["ssim_floor"], f.scores.ssim, 1e-5);
    EXPECT_NEAR(v["psnr_floor"], *f.scores.psnr, 1e-3);
    EXPECT_NEAR(v["rmse_floor"] / f.scores.rmse, 1.0, 1e-5);
    EXPECT_NEAR(v["relmse_floor"] / f.scores.relmse, 1.0, 1e-5);
    EXPECT_NEAR(v["mse_unbiased"] / u.mse, 1.0, 1e-5);
    EXPECT_NEAR(v["relmse_unbiased"] / u.relmse, 1.0, 1e-5);
    // The floors are real: 8 samples leave noise, and the grey scores well above it.
    EXPECT_GT(v["flip_floor"], 0.0);
    EXPECT_GT(v["flip"], 4 * v["flip_floor"]);
    // cell.json: the per-class means (one frame: the row itself) under the reference's key.
    const nlohmann::json& means = ref.name == "full" ? result.means : result.bounce_matched_means;
    EXPECT_NEAR(means["combined"]["flip_floor"].get<double>(), f.scores.flip.mean, 1e-9);
    EXPECT_NEAR(means["combined"]["mse_floor_halves"].get<double>(), f.mse_from_halves, 1e-12);
    EXPECT_EQ(means["combined"]["frames"].get<int>(), 1);
  }
  EXPECT_EQ(result.bounce_matched_means["max_bounces"].get<uint32_t>(),
            trace::bounces_matching_photon_technique(4));
  ASSERT_EQ(result.references.size(), 2u);
  EXPECT_EQ(result.references[1]["reference"], "bounce_matched");
  EXPECT_EQ(result.references[1]["samples"].get<uint32_t>(), 8u);
  // The report's images come from the full reference only.
  EXPECT_TRUE(std::filesystem::exists(dir / "images" / "reference_0000_combined.png"));
  // cell.json carries all three: what the cell runner copies into its record.
  CellRecord cell_record(cell);
  cell_record.metrics = result.means;
  cell_record.metrics_bounce_matched = result.bounce_matched_means;
  cell_record.references = result.references;
  const nlohmann::json record = to_json(cell_record);
  EXPECT_TRUE(record.contains("metrics") && record.contains("metrics_bounce_matched") &&
              record.contains("references"));
}

// The config's `metrics` names what is scored and written: metrics.csv's columns, cell.json's means
// and the FLIP error maps; mae is scored (with its floor) when named.
TEST(Scoring, OnlyTheNamedMetricsAreWritten) {
  const scene::Scene scene = scene::load_scene(PB_SOURCE_DIR "/scenes/cornell-box.yaml");
  io::Image output(32, 18, 4);
  for (size_t i = 0; i < output.pixels.size(); ++i) output.pixels[i] = i % 4 == 3 ? 1.f : 0.3f;
  const std::string reference =
      fmt::format("reference: {{samples: 8, cache_dir: {}}}\n", (kTemp / "named").string());
  auto score = [&](const std::string& metrics, const std::string& name) {
    const std::filesystem::path dir = kTemp / name;
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir / "images");
    io::write_image(dir / "images" / "frame_0000.exr", output);
    const ScoreResult result = score_cell(load("metrics: " + metrics + "\n" + reference), Cell{},
                                          scene, {0}, "combined", dir);
    return std::make_pair(io::read_csv(dir / "metrics.csv"), result.means["combined"]);
  };

  const auto [flip_csv, flip_means] = score("[flip]", "flip");
  ASSERT_EQ(flip_csv.size(), 2u);
  EXPECT_EQ(flip_csv[0], (std::vector<std::string>{"frame", "path_class", "reference", "flip",
                                                   "flip_floor", "flicker", "flicker_floor"}));
  for (const char* absent :
       {"ssim", "psnr", "ssim_floor", "psnr_floor", "rmse", "mse_unbiased", "mse_floor"})
    EXPECT_FALSE(flip_means.contains(absent)) << absent;
  EXPECT_TRUE(flip_means.contains("flip_floor"));
  EXPECT_TRUE(std::filesystem::exists(kTemp / "flip" / "images" / "flip_0000_combined.png"));

  const auto [mae_csv, mae_means] = score("[mae, rmse]", "mae");
  EXPECT_EQ(mae_csv[0], (std::vector<std::string>{"frame", "path_class", "reference", "rmse", "mae",
                                                  "rmse_floor", "mae_floor", "mse_unbiased",
                                                  "flicker", "flicker_floor"}));
  trace::ReferenceCache cache(kTemp / "named");
  const auto entry = cache.get_entry(scene, scene.at(0), trace::PathClass::combined, 32, 18,
                                     reference_options(load(reference), 0));
  ASSERT_TRUE(entry);
  const metrics::Scores s = metrics::evaluate(entry->mean, output);
  const metrics::NoiseFloor f =
      metrics::noise_floor({entry->mean, entry->variance, entry->half[0], entry->half[1]});
  EXPECT_NEAR(std::stod(mae_csv[1][4]) / s.mae, 1.0, 1e-5);
  EXPECT_NEAR(std::stod(mae_csv[1][6]) / f.scores.mae, 1.0, 1e-5);
  EXPECT_NEAR(mae_means["mae"].get<double>() / s.mae, 1.0, 1e-5);
  EXPECT_TRUE(mae_means.contains("mse_floor"));
  EXPECT_FALSE(mae_means.contains("flip"));
  EXPECT_FALSE(std::filesystem::exists(kTemp / "mae" / "images" / "flip_0000_combined.png"))
      << "no FLIP error map when FLIP is not scored";

  // No metrics: nothing scored, and no reference rendered for it (a timing-only run).
  const std::string unscored_cache = (kTemp / "unscored-cache").string();
  std::filesystem::remove_all(unscored_cache);
  const std::filesystem::path dir = kTemp / "none";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "images");
  io::write_image(dir / "images" / "frame_0000.exr", output);
  const ScoreResult none = score_cell(
      load(fmt::format("metrics: []\nreference: {{samples: 8, cache_dir: {}}}\n", unscored_cache)),
      Cell{}, scene, {0}, "combined", dir);
  EXPECT_TRUE(none.references.empty());
  EXPECT_EQ(io::read_csv(dir / "metrics.csv").size(), 1u) << "the header only";
  EXPECT_FALSE(std::filesystem::exists(unscored_cache) &&
               !std::filesystem::is_empty(unscored_cache))
      << "a reference was rendered for a run that scores nothing";
}

}  // namespace scoring_test
}  // namespace pb::run
