// Matching (`match:`) without running a cell: the search on known functions of the knob (a cost
// linear in it, an error falling as 1/sqrt of it, a target out of reach, a failing probe), and the
// match plan's refusals of bad input, each at its file, line and key, before any work.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <set>

#include "photonbench/error.h"
#include "plan/match_plan.h"
#include "run/match_search.h"

namespace pb::run {
namespace match_test {

namespace fs = std::filesystem;

// A photon count: whole numbers in [1, 1e5], bracketed by factors of 2.
constexpr KnobSpace kCountKnob{1, 1e5, true, true};

// The search on f, counting the probes and checking each value is measured once.
SearchResult search(const KnobSpace& space, const SearchTarget& target, double start,
                    const std::function<double(double)>& f) {
  std::set<std::string> seen;
  return search_knob(space, target, start, [&](const std::string& text) {
    EXPECT_TRUE(seen.insert(text).second) << "probed twice: " << text;
    return Measured{f(std::stod(text)), MatchStatus::matched, ""};
  });
}

double found_value(const SearchResult& r) { return *r.probes[*r.best].measured.value; }

TEST(MatchSearch, AFrameTimeLinearInTheKnobIsMatchedWithinTheTolerance) {
  // 5 ms of fixed cost and 0.2 ms per unit: 250 ms at 1225, reached from 16 in either direction.
  const auto cost = [](double x) { return 5 + 0.2 * x; };
  for (double start : {16.0, 1.0, 90000.0}) {
    const SearchResult r = search(kCountKnob, {250, 0.05, 1, 12}, start, cost);
    ASSERT_EQ(r.status, MatchStatus::matched) << "from " << start << ": " << r.reason;
    EXPECT_NEAR(found_value(r), 250, 0.05 * 250) << "from " << start;
    EXPECT_LE(r.probes.size(), 12u);
    EXPECT_EQ(r.probes.front().knob, start) << "the first probe is the start value";
  }
  // A tighter tolerance takes more probes and still lands inside it.
  const SearchResult tight = search(kCountKnob, {250, 0.005, 1, 24}, 16, cost);
  ASSERT_EQ(tight.status, MatchStatus::matched) << tight.reason;
  EXPECT_NEAR(found_value(tight), 250, 0.005 * 250);
}

TEST(MatchSearch, AnErrorFallingWithTheKnobIsMatchedWithinTheTolerance) {
  // A Monte Carlo error: 0.01 + 1/sqrt(n); 0.1 at n = 123.5.
  const auto error = [](double n) { return 0.01 + 1 / std::sqrt(n); };
  const SearchResult r = search(kCountKnob, {0.1, 0.05, -1, 12}, 16, error);
  ASSERT_EQ(r.status, MatchStatus::matched) << r.reason;
  EXPECT_NEAR(found_value(r), 0.1, 0.005);
  const double n = r.probes[*r.best].knob;
  EXPECT_GT(n, 90);
  EXPECT_LT(n, 170);
  // A float knob on a linear scale (a cost falling as the knob grows, as AAPS's target area).
  const KnobSpace area{0.5, 100, false, false};
  const SearchResult a =
      search(area, {40, 0.02, -1, 16}, 19, [](double x) { return 100 - 0.9 * x; });
  ASSERT_EQ(a.status, MatchStatus::matched) << a.reason;
  EXPECT_NEAR(found_value(a), 40, 0.8);
}

TEST(MatchSearch, ATargetNoValueReachesIsUnreachableSayingTheRangeReached) {
  const auto cost = [](double x) { return 5 + 0.2 * x; };
  // Above: the knob climbs to the range's end (1e5: 20005 ms) and stops there.
  SearchResult r = search(kCountKnob, {1e6, 0.05, 1, 40}, 16, cost);
  ASSERT_EQ(r.status, MatchStatus::unreachable) << r.reason;
  EXPECT_EQ(r.probes.back().knob, 1e5);
  EXPECT_NE(r.reason.find("no value in [1, 100000] reaches 1e+06"), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find("the probes reached 8.2 (at 16) to "), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find(" (at 100000)"), std::string::npos) << r.reason;
  ASSERT_TRUE(r.best);
  EXPECT_EQ(r.probes[*r.best].knob, 1e5) << "the closest probe is kept";
  // Below the fixed cost: down to 1 and no further.
  r = search(kCountKnob, {2, 0.05, 1, 40}, 16, cost);
  ASSERT_EQ(r.status, MatchStatus::unreachable) << r.reason;
  EXPECT_EQ(r.probes.back().knob, 1);
  EXPECT_EQ(r.probes.size(), 4u) << "16, 8 (by 2), 2 (by 4), 1 (by 8, the range's end)";
}

TEST(MatchSearch, EndsWithinItsProbesOnANoisyOrCoarseMeasure) {
  // +-4% of deterministic noise against a 1% tolerance: converged or not, never more probes.
  int calls = 0;
  const SearchResult noisy = search(kCountKnob, {250, 0.01, 1, 8}, 16, [&](double x) {
    return (5 + 0.2 * x) * (1 + 0.04 * std::sin(12.9898 * ++calls));
  });
  EXPECT_LE(noisy.probes.size(), 8u);
  EXPECT_TRUE(noisy.status == MatchStatus::matched || noisy.status == MatchStatus::not_converged)
      << match_status_name(noisy.status);
  ASSERT_TRUE(noisy.best);
  // A whole-number knob whose neighbours straddle the target: the bracket runs out of values.
  const SearchResult coarse =
      search({1, 64, true, true}, {105, 0.001, 1, 40}, 4, [](double x) { return 10.0 * x; });
  EXPECT_EQ(coarse.status, MatchStatus::not_converged) << coarse.reason;
  EXPECT_NE(coarse.reason.find("the bracket [10, 11] holds no untried value"), std::string::npos)
      << coarse.reason;
}

TEST(MatchSearch, AProbeThatFailsOrRefusesStopsTheSearchWithItsReason) {
  int calls = 0;
  const SearchResult r = search_knob(kCountKnob, {250, 0.05, 1, 12}, 16, [&](const std::string&) {
    return ++calls == 1 ? Measured{50.0, MatchStatus::matched, ""}
                        : Measured{std::nullopt, MatchStatus::failed, "probe cell x failed: NaN"};
  });
  EXPECT_EQ(r.status, MatchStatus::failed);
  EXPECT_EQ(r.reason, "probe cell x failed: NaN");
  EXPECT_EQ(r.probes.size(), 2u);
  const SearchResult floor = search_knob(kCountKnob, {0.01, 0.05, -1, 12}, 16, [](const auto&) {
    return Measured{std::nullopt, MatchStatus::below_floor, "below 4x the floor"};
  });
  EXPECT_EQ(floor.status, MatchStatus::below_floor);
  EXPECT_EQ(floor.probes.size(), 1u);
  EXPECT_FALSE(floor.best);
}

TEST(MatchSearch, KnobValuesAreWrittenAsTheSchemaWritesThem) {
  EXPECT_EQ(knob_text(kCountKnob, 1224.6), "1225");
  EXPECT_EQ(knob_text(kCountKnob, 3e5), "100000");
  EXPECT_EQ(knob_text({0.5, 100, false, true}, 19), "19");
  EXPECT_EQ(knob_text({0.5, 100, false, true}, 0.1), "0.5");
  EXPECT_EQ(knob_text({0.5, 100, false, true}, 2.25), "2.25");
}

// ---- the match plan: bad input at its file, line and key ----

class MatchPlanTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("pb_match_plan_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  MatchPlan plan(const std::string& yaml) {
    std::ofstream(dir_ / "config.yaml")
        << yaml << "plugin_dirs: [" PB_BINARY_DIR "/plugins, " PB_BINARY_DIR "/test-plugins]\n";
    plan_ = std::make_unique<RunPlan>(plan_run(dir_ / "config.yaml", {}));
    return plan_matches(*plan_);
  }
  // The InputError planning `yaml` throws ("" when it plans).
  std::string error(const std::string& yaml) {
    try {
      plan(yaml);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
  std::unique_ptr<RunPlan> plan_;
};

const std::string kHead =
    "name: t\nresolution: [32, 18]\nframes: {warmup: 0, count: 5}\nscenes: [cornell-box]\n";

TEST_F(MatchPlanTest, EachTechniqueGetsItsFirstBudgetKnobOrTheOneNamed) {
  const MatchPlan m = plan(kHead + R"(match: {at: time, frame_ms: 250}
techniques:
  - technique: tiled
    params: {photons: 20000, radius: 0.1}
  - technique: tiled
    knob: radius
    knob_range: [0.01, 0.2]
  - technique: aaps
  - technique: direct
    match: false
)");
  ASSERT_EQ(m.matches.size(), 3u);
  EXPECT_EQ(m.matches[0].knob, "photons");
  EXPECT_EQ(m.matches[0].start.params.at("photons"), "20000") << "the config's value starts";
  EXPECT_TRUE(m.matches[0].space.integer && m.matches[0].space.log);
  EXPECT_EQ(m.matches[0].space.hi, 5e7);
  EXPECT_EQ(m.matches[0].direction, 1);
  EXPECT_EQ(m.matches[1].knob, "radius");
  EXPECT_EQ(m.matches[1].space.lo, 0.01);
  EXPECT_EQ(m.matches[1].start.params.at("radius"), "0.05");
  EXPECT_EQ(m.matches[2].knob, "target_area");
  EXPECT_EQ(m.matches[2].direction, -1) << "a larger target area costs less";
  ASSERT_EQ(m.unmatched.size(), 1u);
  EXPECT_EQ(m.unmatched[0].technique, "direct");
  // A start outside knob_range moves inside it, and is then a cell of its own.
  const MatchPlan moved = plan(kHead + R"(match: {at: quality, metric: flip, value: 0.2}
techniques:
  - technique: tiled
    knob_range: [1000, 50000]
)");
  EXPECT_EQ(moved.matches[0].start.params.at("photons"), "50000");
  EXPECT_EQ(moved.matches[0].direction, -1) << "more photons, less error";
  EXPECT_EQ(moved.matches[0].start.id, with_knob(moved.matches[0].start, "photons", "50000", 1).id);
}

TEST_F(MatchPlanTest, AKnobThatIsNotABudgetKnobIsAnErrorAtItsKey) {
  std::string e = error(kHead + R"(match: {at: time, frame_ms: 250}
techniques:
  - technique: tiled
    knob: shadow_map_size
)");
  EXPECT_NE(e.find("config.yaml:8:"), std::string::npos) << e;
  EXPECT_NE(e.find("techniques[0].knob: 'shadow_map_size' is not a budget knob of technique "
                   "'tiled' (its budget knobs: photons, radius)"),
            std::string::npos)
      << e;
  // match.knob for every technique: at match.knob.
  e = error(kHead +
            "match: {at: time, frame_ms: 250, knob: photons}\n"
            "techniques: [{technique: aaps}]\n");
  EXPECT_NE(e.find("config.yaml:5:"), std::string::npos) << e;
  EXPECT_NE(e.find("match.knob: 'photons' is not a budget knob of technique 'aaps' (its budget "
                   "knobs: target_area)"),
            std::string::npos)
      << e;
}

TEST_F(MatchPlanTest, ATechniqueWithoutABudgetKnobIsAnErrorUnlessItIsABaseline) {
  const std::string e =
      error(kHead + "match: {at: time, frame_ms: 250}\ntechniques:\n  - technique: direct\n");
  EXPECT_NE(e.find("config.yaml:7:"), std::string::npos) << e;
  EXPECT_NE(e.find("techniques[0].technique: technique 'direct' declares no budget knob"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("give it `match: false`"), std::string::npos) << e;
  EXPECT_EQ(error(kHead + "match: {at: time, frame_ms: 250}\ntechniques:\n"
                          "  - {technique: direct, match: false}\n  - technique: tiled\n"),
            "");
}

TEST_F(MatchPlanTest, BadMatchBlocksAreRefusedBeforeAnyWork) {
  const std::string tiled = "techniques: [{technique: tiled}]\n";
  struct Case {
    std::string yaml, where, what;
  };
  const std::vector<Case> cases = {
      {"match: {at: quality, metric: flip, value: 0.1, knob: radius}\n" + tiled, "match.at",
       "the error of technique 'tiled' is not monotone in 'radius'"},
      {"match: {at: time}\n" + tiled, "match:", "at: time needs 'frame_ms'"},
      {"match: {at: time, frame_ms: 10, metric: flip}\n" + tiled, "match.metric",
       "'metric' is not a key of at: time"},
      {"match: {at: quality, metric: mae, value: 0.1}\n" + tiled, "match.metric",
       "'mae' is not scored by this run (metrics: flip, ssim, psnr, rmse, relmse)"},
      {"match: {at: quality, metric: ssim, value: 0.9}\n" + tiled, "match.metric", "ssim"},
      {"match: {at: time, frame_ms: 10}\ntechniques:\n  - technique: tiled\n    params: "
       "{photons: [1000, 2000]}\n",
       "techniques[0].params.photons", "'photons' is the knob this match searches"},
      {"match: {at: time, frame_ms: 10}\ntechniques:\n  - {technique: tiled, knob_range: [0, "
       "10]}\n",
       "techniques[0].knob_range", "[0, 10] is outside the range of 'photons', [1, "},
      {"techniques:\n  - {technique: tiled, knob: photons}\n", "techniques[0].knob",
       "'knob' of a technique needs the config's `match` block"},
  };
  for (const Case& c : cases) {
    const std::string e = error(kHead + c.yaml);
    EXPECT_NE(e.find("config.yaml:"), std::string::npos) << c.yaml << " -> " << e;
    EXPECT_NE(e.find(c.where), std::string::npos) << c.yaml << " -> " << e;
    EXPECT_NE(e.find(c.what), std::string::npos) << c.yaml << " -> " << e;
  }
  // A median frame time over fewer than 5 frames is refused.
  const std::string e = error(
      "name: t\nframes: {count: 3}\nscenes: [cornell-box]\nmatch: {at: time, frame_ms: 10}\n" +
      tiled);
  EXPECT_NE(e.find("match.at: at: time takes each probe's median frame time, over at least 5"),
            std::string::npos)
      << e;
}

TEST_F(MatchPlanTest, APluginOfApiVersion4IsRefusedNamingBothVersionsAndWhatChanged) {
  PluginRegistry plugins({fs::path(PB_BINARY_DIR) / "test-plugins"});
  const Plugin* v4 = plugins.find("api_v4");
  ASSERT_NE(v4, nullptr);
  EXPECT_FALSE(v4->loaded());
  EXPECT_NE(v4->load_error.find("was built for plugin API version 4"), std::string::npos)
      << v4->load_error;
  EXPECT_NE(v4->load_error.find("this photonbench has 6"), std::string::npos) << v4->load_error;
  EXPECT_NE(v4->load_error.find("version 5: the photon tracer's modes"), std::string::npos)
      << v4->load_error;
  EXPECT_NE(v4->load_error.find("version 6: the photon tracer computes ray differentials"),
            std::string::npos)
      << v4->load_error;
  EXPECT_EQ(v4->load_error.find("version 4:"), std::string::npos)
      << "a version-4 module needs only the changes of versions 5 and 6: " << v4->load_error;
  const Plugin* knob = plugins.find("budget_knob");
  ASSERT_TRUE(knob && knob->loaded()) << (knob ? knob->load_error : "not found");
  ASSERT_EQ(knob->descriptor->budget_count, 2u);
  EXPECT_STREQ(knob->descriptor->budget[0].param, "samples");
  EXPECT_EQ(knob->descriptor->budget[0].scale, PB_SCALE_LOG);
}

}  // namespace match_test
}  // namespace pb::run
