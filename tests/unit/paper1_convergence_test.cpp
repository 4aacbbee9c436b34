// Paper I's splatting techniques converge like photon mapping: with more photons of a
// smaller radius, each technique's indirect-diffuse estimate (the image it hands to the shared
// shade pass, scored alone against the path-traced `indirect` reference) gets closer to the
// reference. Three steps, photons x8 and radius / 2 a step (variance ~ 1 / (N r^2) halves, bias ~
// r^2 quarters); relMSE must fall at every step. One run holds every technique's three cells so the
// references render once.
#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "run_fixture.h"

namespace paper1_convergence_test {

using namespace pb::testing;

struct Step {
  int photons;
  double radius;
};
const Step kSteps[] = {{4000, 0.16}, {32000, 0.08}, {256000, 0.04}};
const std::vector<std::string> kTechniques = {"tiled", "cluster", "directional"};

// One test over the three techniques, not one per technique: CTest runs every GoogleTest test in
// a process of its own, so each of three would render all nine cells and the references again.
TEST(Paper1Convergence, IndirectRelMseFallsAsPhotonsGrowAndRadiusShrinks) {
  const fs::path dir = work_dir("paper1", "convergence");
  std::string yaml =
      "name: paper1-convergence\nresolution: [96, 54]\nseed: 3\nscenes: [cornell-box]\n"
      "frames: {warmup: 0, count: 1, metrics_every: 1}\nmetrics: [relmse]\n"
      "limits: {cell_seconds: 600}\n"
      "reference: {samples: 1024, cache_dir: " +
      (dir / "refs").string() + "}\ntechniques:\n";
  for (const std::string& technique : kTechniques)
    for (const Step& step : kSteps)
      yaml += "  - technique: " + technique +
              "\n    params: {photons: " + std::to_string(step.photons) +
              ", radius: " + std::to_string(step.radius) + ", max_bounces: 12}\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << "see " << (dir / "log.txt");

  // indirect-class relMSE of each cell, by (technique, photons).
  std::map<std::pair<std::string, int>, double> relmse;
  for (const auto& entry : fs::directory_iterator(dir / "run" / "cells")) {
    const auto cell = read_json(entry.path() / "cell.json");
    if (cell["status"] != "ok" || !cell["metrics"].contains("indirect")) continue;
    relmse[{cell["technique"].get<std::string>(),
            std::stoi(cell["params"]["photons"].get<std::string>())}] =
        cell["metrics"]["indirect"]["relmse"].get<double>();
  }
  for (const std::string& technique : kTechniques) {
    SCOPED_TRACE(technique);
    std::vector<double> errors;
    for (const Step& step : kSteps) {
      auto it = relmse.find({technique, step.photons});
      ASSERT_NE(it, relmse.end()) << technique << " with " << step.photons
                                  << " photons has no indirect score (see " << dir << ")";
      errors.push_back(it->second);
    }
    std::printf("%s indirect relMSE: %.4f -> %.4f -> %.4f\n", technique.c_str(), errors[0],
                errors[1], errors[2]);
    for (size_t i = 1; i < errors.size(); ++i)
      EXPECT_LT(errors[i], errors[i - 1])
          << technique << ": relMSE " << errors[0] << " -> " << errors[1] << " -> " << errors[2];
  }
  if (!::testing::Test::HasFailure()) fs::remove_all(dir);
}

}  // namespace paper1_convergence_test
