// Paper I's splatting techniques converge like photon mapping: with more photons of a
// smaller radius, each technique's indirect-diffuse estimate (the image it hands to the shared
// shade pass, scored alone against the path-traced `indirect` reference) gets closer to the
// reference. Three steps, photons x8 and radius / 2 a step (variance ~ 1 / (N r^2) halves, bias ~
// r^2 quarters); relMSE must fall at every step. One run holds every technique's three cells so the
// references render once.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace paper1_convergence_test {

struct Step {
  int photons;
  double radius;
};
const Step kSteps[] = {{4000, 0.16}, {32000, 0.08}, {256000, 0.04}};
const std::vector<std::string> kTechniques = {"tiled", "cluster", "directional"};

fs::path g_dir;
int g_exit = -1;

// indirect-class relMSE of each cell, by (technique, photons).
std::map<std::pair<std::string, int>, double> g_relmse;

class Paper1Convergence : public ::testing::TestWithParam<std::string> {
 public:
  static void SetUpTestSuite() {
    g_dir = fs::temp_directory_path() / ("pb_convergence_" + std::to_string(::getpid()));
    fs::remove_all(g_dir);
    fs::create_directories(g_dir);
    std::string yaml =
        "name: paper1-convergence\nresolution: [96, 54]\nseed: 3\nscenes: [cornell-box]\n"
        "frames: {warmup: 0, count: 1, metrics_every: 1}\nmetrics: [relmse]\n"
        "limits: {cell_seconds: 600}\n"
        "reference: {samples: 1024, cache_dir: " +
        (g_dir / "refs").string() + "}\ntechniques:\n";
    for (const std::string& technique : kTechniques)
      for (const Step& step : kSteps)
        yaml += "  - technique: " + technique +
                "\n    params: {photons: " + std::to_string(step.photons) +
                ", radius: " + std::to_string(step.radius) + ", max_bounces: 12}\n";
    std::ofstream(g_dir / "config.yaml") << yaml;
    std::string cmd = std::string(PB_BINARY_DIR "/photonbench run ") +
                      (g_dir / "config.yaml").string() + " --out " + (g_dir / "run").string() +
                      " > " + (g_dir / "log.txt").string() + " 2>&1";
    g_exit = std::system(cmd.c_str());
    for (const auto& entry : fs::directory_iterator(g_dir / "run" / "cells")) {
      std::ifstream in(entry.path() / "cell.json");
      auto cell = nlohmann::json::parse(in);
      if (cell["status"] != "ok" || !cell["metrics"].contains("indirect")) continue;
      g_relmse[{cell["technique"].get<std::string>(),
                std::stoi(cell["params"]["photons"].get<std::string>())}] =
          cell["metrics"]["indirect"]["relmse"].get<double>();
    }
  }
  static void TearDownTestSuite() {
    if (!::testing::Test::HasFailure()) fs::remove_all(g_dir);
  }
};

TEST_P(Paper1Convergence, IndirectRelMseFallsAsPhotonsGrowAndRadiusShrinks) {
  ASSERT_EQ(g_exit, 0) << "see " << (g_dir / "log.txt");
  std::vector<double> errors;
  for (const Step& step : kSteps) {
    auto it = g_relmse.find({GetParam(), step.photons});
    ASSERT_NE(it, g_relmse.end()) << GetParam() << " with " << step.photons
                                  << " photons has no indirect score (see " << g_dir << ")";
    errors.push_back(it->second);
  }
  std::printf("%s indirect relMSE: %.4f -> %.4f -> %.4f\n", GetParam().c_str(), errors[0],
              errors[1], errors[2]);
  for (size_t i = 1; i < errors.size(); ++i)
    EXPECT_LT(errors[i], errors[i - 1])
        << GetParam() << ": relMSE " << errors[0] << " -> " << errors[1] << " -> " << errors[2];
}

INSTANTIATE_TEST_SUITE_P(Techniques, Paper1Convergence, ::testing::ValuesIn(kTechniques));

}  // namespace paper1_convergence_test
