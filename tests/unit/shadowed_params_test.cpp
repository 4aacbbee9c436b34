// A scene entry's params replace the same parameter of every technique that has it: where the
// technique entry (or --set) sets that parameter too, the plan says so, naming both keys, and
// refuses a replacement that would collapse the entry's sweep.
#include <gtest/gtest.h>

#include <string>

#include "photonbench/error.h"
#include "plan_scratch.h"

namespace pb::run {
namespace shadowed_params_test {

const std::string kConfig = R"(name: shadowed
resolution: [64, 36]
frames: {warmup: 0, count: 1, metrics_every: 0}
scenes:
  - {scene: cornell-box, params: {photons: 10000}}
techniques:
  - technique: direct
  - technique: tiled
)";

std::string photons_of(const RunPlan& plan) {
  std::string values;
  for (const Cell& cell : plan.cells)
    if (cell.technique == "tiled") values += cell.params.at("photons") + " ";
  return values;
}

TEST(ShadowedParams, NoWarningWhereOnlyTheSceneSetsIt) {
  testing::PlanScratch scratch("shadowed_params");
  const RunPlan plan = scratch.plan(kConfig);
  EXPECT_TRUE(plan.warnings.empty()) << plan.warnings.front();
  EXPECT_EQ(photons_of(plan), "10000 ");
}

TEST(ShadowedParams, ASetValueTheSceneReplacesIsAWarningNamingBothKeys) {
  testing::PlanScratch scratch("shadowed_params");
  const RunPlan plan = scratch.plan(kConfig, {"techniques.1.params.photons=5000"});
  ASSERT_EQ(plan.warnings.size(), 1u);
  const std::string& warning = plan.warnings[0];
  EXPECT_NE(warning.find("config.yaml:5:"), std::string::npos) << warning;
  EXPECT_NE(warning.find("scenes[0].params.photons = 10000 replaces techniques[1].params.photons = "
                         "5000 ("),
            std::string::npos)
      << warning;
  EXPECT_NE(warning.find("config.yaml (--set techniques.1.params.photons=5000)) for technique "
                         "'tiled' on scene 'cornell-box'"),
            std::string::npos)
      << warning;
  EXPECT_EQ(photons_of(plan), "10000 ");
}

TEST(ShadowedParams, TheSameValueTwiceIsNoWarning) {
  testing::PlanScratch scratch("shadowed_params");
  EXPECT_TRUE(scratch.plan(kConfig, {"techniques.1.params.photons=10000"}).warnings.empty());
}

TEST(ShadowedParams, ASweepTheSceneWouldCollapseIsAnError) {
  testing::PlanScratch scratch("shadowed_params");
  try {
    scratch.plan(kConfig, {"techniques.1.params.photons=[5000,20000]"});
    FAIL() << "a sweep of two values collapsed to the scene's one";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("config.yaml:5:"), std::string::npos) << message;
    EXPECT_NE(message.find("scenes[0].params.photons: 10000 on scene 'cornell-box' replaces "
                           "techniques[1].params.photons = [5000, 20000]"),
              std::string::npos)
        << message;
    EXPECT_NE(message.find("collapsing that sweep of 2 values to 1 on every scene 'tiled' runs on"),
              std::string::npos)
        << message;
  }
}

TEST(ShadowedParams, ASweepAnotherSceneKeepsIsAWarning) {
  testing::PlanScratch scratch("shadowed_params");
  std::string config = kConfig;
  config.replace(config.find("  - {scene: cornell-box"), 0, "  - pillars\n");
  const RunPlan plan = scratch.plan(config, {"techniques.1.params.photons=[5000,20000]"});
  ASSERT_EQ(plan.warnings.size(), 1u);
  EXPECT_NE(plan.warnings[0].find("on scene 'cornell-box'"), std::string::npos) << plan.warnings[0];
  EXPECT_EQ(photons_of(plan), "5000 20000 10000 ");
}

}  // namespace shadowed_params_test
}  // namespace pb::run
