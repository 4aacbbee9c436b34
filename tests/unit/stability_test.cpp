// The stability classifier (run/stability.h): each rule of ok, degraded, failed and unrated, and
// what it reads of a cell record.
#include "run/stability.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace pb::run {
namespace stability_test {

CellOutcome scored(double flip, std::optional<double> floor = std::nullopt) {
  CellOutcome c;
  c.status = "ok";
  c.flip = flip;
  c.flip_floor = floor;
  return c;
}

TEST(StabilityClassifier, AFailedCellIsFailedWithTheHarnessReason) {
  CellOutcome c;
  c.status = "failed";
  c.reason = "crashed (signal 11, SIGSEGV) at frame 3";
  const CellOutcome base = scored(0.1);
  const Verdict v = classify_cell(c, &base, {});
  EXPECT_EQ(v.verdict, StabilityClass::failed);
  EXPECT_EQ(v.reason, c.reason);
}

TEST(StabilityClassifier, AWarningDuringAFrameFailsTheCell) {
  CellOutcome c = scored(0.1);
  c.frame_warnings = {{5, "tiled: per-tile photon lists overflowed"}, {6, "again"}};
  const CellOutcome base = scored(0.1);
  const Verdict v = classify_cell(c, &base, {});
  EXPECT_EQ(v.verdict, StabilityClass::failed);
  EXPECT_EQ(v.reason,
            "warning at frame 5: tiled: per-tile photon lists overflowed (and 1 more warnings)");
}

TEST(StabilityClassifier, ErrorBeyondTheFactorOfTheBaselineIsDegraded) {
  StabilityRules rules;
  rules.degraded_factor = 2.0;
  const CellOutcome base = scored(0.1, 0.005);
  const Verdict degraded = classify_cell(scored(0.3, 0.01), &base, rules);
  EXPECT_EQ(degraded.verdict, StabilityClass::degraded);
  ASSERT_TRUE(degraded.ratio);
  EXPECT_NEAR(*degraded.ratio, 3.0, 1e-12);
  EXPECT_NE(degraded.reason.find("3.00x"), std::string::npos) << degraded.reason;
  // Just inside the factor: ok, with its ratio.
  const Verdict ok = classify_cell(scored(0.19, 0.01), &base, rules);
  EXPECT_EQ(ok.verdict, StabilityClass::ok);
  EXPECT_NEAR(*ok.ratio, 1.9, 1e-12);
  // A larger factor lets the same cell pass.
  rules.degraded_factor = 4.0;
  EXPECT_EQ(classify_cell(scored(0.3, 0.01), &base, rules).verdict, StabilityClass::ok);
}

TEST(StabilityClassifier, AnErrorInsideTheNoiseFloorIsNotDegraded) {
  // 0.3 is 3x the baseline but under 4x its floor of 0.1: the reference cannot tell it from noise.
  const CellOutcome base = scored(0.1, 0.02);
  const Verdict v = classify_cell(scored(0.3, 0.1), &base, {});
  EXPECT_EQ(v.verdict, StabilityClass::ok);
  EXPECT_NE(v.reason.find("noise floor"), std::string::npos) << v.reason;
  StabilityRules loose;
  loose.resolved_floor_factor = 2.0;  // resolved at 2x the floor: 0.3 >= 0.2
  EXPECT_EQ(classify_cell(scored(0.3, 0.1), &base, loose).verdict, StabilityClass::degraded);
}

TEST(StabilityClassifier, AFailedBaselineLeavesTheCellUnrated) {
  CellOutcome base;
  base.status = "failed";
  EXPECT_EQ(classify_cell(scored(0.2), &base, {}).verdict, StabilityClass::unrated);
  CellOutcome warned = scored(0.1);
  warned.frame_warnings = {{2, "overflow"}};
  EXPECT_EQ(classify_cell(scored(0.2), &warned, {}).verdict, StabilityClass::unrated);
  // A baseline row itself (no baseline to compare with) is ok when it ran cleanly.
  EXPECT_EQ(classify_cell(scored(0.2), nullptr, {}).verdict, StabilityClass::ok);
  // A cell without a score cannot be rated.
  CellOutcome unscored;
  unscored.status = "ok";
  EXPECT_EQ(classify_cell(unscored, &base, {}).verdict, StabilityClass::unrated);
}

TEST(StabilityClassifier, FlickerAboveItsBoundIsDegraded) {
  CellOutcome c = scored(0.1);
  c.flicker = 0.5;
  const CellOutcome base = scored(0.1);
  EXPECT_EQ(classify_cell(c, &base, {}).verdict, StabilityClass::ok);  // no bound: not judged
  StabilityRules rules;
  rules.flicker_bound = 0.2;
  const Verdict v = classify_cell(c, &base, rules);
  EXPECT_EQ(v.verdict, StabilityClass::degraded);
  EXPECT_NE(v.reason.find("flicker 0.5"), std::string::npos) << v.reason;
  c.flicker = 0.1;
  EXPECT_EQ(classify_cell(c, &base, rules).verdict, StabilityClass::ok);
}

TEST(StabilityClassifier, WorseThanNoIndirectLightAtAllIsDegraded) {
  // Light leaking out of a closed box: 0.03 is well under the baseline's 0.2, but 20x what direct
  // light alone scores on the same scene.
  StabilityRules rules;
  rules.no_gi_technique = "direct";
  const CellOutcome base = scored(0.2, 0.01), direct = scored(0.0015, 0.0008);
  const CellOutcome leaking = scored(0.03, 0.0008);
  EXPECT_EQ(classify_cell(leaking, &base, rules).verdict, StabilityClass::ok);
  const Verdict v = classify_cell(leaking, &base, rules, &direct);
  EXPECT_EQ(v.verdict, StabilityClass::degraded);
  EXPECT_NE(v.reason.find("20x direct's 0.0015"), std::string::npos) << v.reason;
  // Within the factor of direct's error, or unresolved from the reference's noise: ok.
  EXPECT_EQ(classify_cell(scored(0.0025, 0.0001), &base, rules, &direct).verdict,
            StabilityClass::ok);
  EXPECT_EQ(classify_cell(scored(0.03, 0.01), &base, rules, &direct).verdict, StabilityClass::ok);
  // A failed no-GI cell is no evidence.
  CellOutcome failed_direct = direct;
  failed_direct.status = "failed";
  EXPECT_EQ(classify_cell(leaking, &base, rules, &failed_direct).verdict, StabilityClass::ok);
}

TEST(StabilityClassifier, WorseThanNoIndirectLightResolvedIsDegradedWithFactorOne) {
  // A leak through a thin wall: 0.745 against direct's 0.690 passes the 2x rule; with
  // no_gi_factor 1 it is worse than no indirect light, resolved when the difference (0.055) is
  // beyond the two noise floors together.
  StabilityRules rules;
  rules.no_gi_technique = "direct";
  const CellOutcome base = scored(0.5, 0.01), direct = scored(0.690, 0.02);
  const CellOutcome leaking = scored(0.745, 0.02);
  EXPECT_EQ(classify_cell(leaking, &base, rules, &direct).verdict, StabilityClass::ok);
  rules.no_gi_factor = 1;
  const Verdict v = classify_cell(leaking, &base, rules, &direct);
  EXPECT_EQ(v.verdict, StabilityClass::degraded);
  EXPECT_NE(v.reason.find("1.08x direct's 0.69"), std::string::npos) << v.reason;
  // Floors of 0.03 each: the difference is within them, so the order is not resolved.
  const CellOutcome noisy_direct = scored(0.690, 0.03);
  EXPECT_EQ(classify_cell(scored(0.745, 0.03), &base, rules, &noisy_direct).verdict,
            StabilityClass::ok);
}

TEST(StabilityClassifier, ReadsTheOutcomeOfACellRecord) {
  const auto file = std::filesystem::temp_directory_path() / "stability_test_cell.json";
  std::ofstream(file) << R"({"status": "ok", "reason": "",
    "warnings": [{"frame": null, "message": "scored as combined"},
                 {"frame": 7, "message": "cluster: the job list overflowed"}],
    "metrics": {"combined": {"flip": 0.25, "flip_floor": 0.03, "ssim": 0.9}}})";
  const CellOutcome c = read_cell_outcome(file);
  std::filesystem::remove(file);
  EXPECT_EQ(c.status, "ok");
  ASSERT_EQ(c.frame_warnings.size(), 1u);  // the set-up/scoring warning (no frame) is not one
  EXPECT_EQ(c.frame_warnings[0].first, 7u);
  EXPECT_EQ(c.frame_warnings[0].second, "cluster: the job list overflowed");
  ASSERT_TRUE(c.flip && c.flip_floor);
  EXPECT_DOUBLE_EQ(*c.flip, 0.25);
  EXPECT_DOUBLE_EQ(*c.flip_floor, 0.03);
  EXPECT_FALSE(c.flicker);
}

}  // namespace stability_test
}  // namespace pb::run
