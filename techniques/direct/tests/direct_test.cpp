// direct, in the order a technique's tests go: it rejects bad parameters with the key (the run's
// own call, in-process), and end to end through `photonbench run` (with Vulkan validation) its
// image is the closed form its passes compute. The scene is lit by one point light alone, so that
// the direct light it estimates has no soft shadows or emitter its passes leave out (README
// "Deviations"): the `direct` class reference (path traced, next-event estimation of a point light)
// is then its exact answer up to anti-aliased edges and the shadow test's bias.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "io/image.h"
#include "photonbench/error.h"
#include "run/runner.h"
#include "run_fixture.h"

namespace fs = std::filesystem;

namespace direct_test {

using namespace pb::testing;

fs::path work_dir(const std::string& name) { return pb::testing::work_dir("direct_test", name); }

// A floor, a box standing on it and a point light above, seen from above at an angle: lit floor,
// the box's lit and unlit faces, and the box's hard shadow on the floor.
const char* kScene =
    R"(purpose: direct light of a point light on a floor and a box, with a hard shadow
fps: 30
frames: 4
camera: {position: [0, 2.2, 2.4], target: [0, 0, 0], fov_deg: 45}
lights:
  - {name: bulb, type: point, position: [0.6, 1.6, 0.4], intensity: 2}
materials:
  floor: {type: diffuse, albedo: 0.7}
  box: {type: diffuse, albedo: [0.8, 0.4, 0.2]}
objects:
  - {name: floor, shape: {type: quad, size: [3, 3]}, material: floor}
  - name: box
    shape: {type: box, size: [0.5, 0.5, 0.5]}
    material: box
    transform: {translate: [0, 0.25, 0]}
)";

std::string config(const fs::path& dir, const std::string& params) {
  std::ofstream(dir / "point-lit.yaml") << kScene;
  return "name: direct-test\nresolution: [128, 72]\nseed: 1\nscenes: [point-lit]\n"
         "frames: {warmup: 0, count: 1, metrics_every: 1}\nlimits: {cell_seconds: 300}\n"
         "reference: {samples: 64, cache_dir: " +
         (dir / "refs").string() +
         "}\n"
         "techniques:\n  - technique: direct\n" +
         (params.empty() ? "" : "    params: {" + params + "}\n");
}

// The reference image of `path_class` at frame 0 in the run's cache.
pb::io::Image reference(const fs::path& dir, const std::string& path_class) {
  for (const auto& entry : fs::directory_iterator(dir / "refs")) {
    if (entry.path().extension() != ".json") continue;
    auto meta = read_json(entry.path());
    if (meta["class"] != path_class || meta["frame"] != 0) continue;
    fs::path exr = entry.path();
    return pb::io::read_image(exr.replace_extension(".exr"));
  }
  ADD_FAILURE() << "no '" << path_class << "' reference of frame 0 in " << dir / "refs";
  return {};
}

// `run` in-process (run::run_benchmark, which the command calls): pb::InputError, the command's
// exit 2, before anything runs.
TEST(DirectParams, RejectsAParameterOutsideItsRangeNamingTheKey) {
  fs::path dir = work_dir("bad_param");
  std::ofstream(dir / "config.yaml") << config(dir, "shadow_map_size: 8");
  pb::run::RunOptions options;
  options.config_file = dir / "config.yaml";
  options.out_dir = dir / "run";
  options.overrides = {"plugin_dirs+=" PB_BINARY_DIR "/plugins"};
  std::string text = "(no error)";
  try {
    pb::run::run_benchmark(options);
  } catch (const pb::InputError& e) {
    text = e.what();
  }
  EXPECT_NE(text.find("config.yaml:"), std::string::npos) << text;
  EXPECT_NE(text.find("shadow_map_size"), std::string::npos) << text;
  EXPECT_FALSE(fs::exists(dir / "run" / "cells")) << "nothing is run before the config is valid";
  fs::remove_all(dir);
}

TEST(Direct, PointLightImageIsTheDirectReference) {
  fs::path dir = work_dir("point_lit");
  ASSERT_EQ(run_config(dir, config(dir, "shadow_map_size: 1024")), 0)
      << "see " << (dir / "log.txt");
  fs::path cell = find_cell(dir, "direct");
  ASSERT_FALSE(cell.empty());
  auto record = read_json(cell / "cell.json");
  EXPECT_EQ(record["status"], "ok") << record.dump();
  EXPECT_EQ(record["validation"], validation_on());
  pb::io::Image image = frame_image(cell, 0), truth = reference(dir, "direct");
  ASSERT_EQ(image.width, truth.width);
  ASSERT_EQ(image.height, truth.height);
  ASSERT_TRUE(all_finite(image));
  // The mean: the light's falloff, the cosines and the albedos, and the shadow's area.
  EXPECT_NEAR(mean_rgb(image) / mean_rgb(truth), 1.0, 0.02)
      << "direct " << mean_rgb(image) << ", reference " << mean_rgb(truth);
  // Pixel by pixel: all but the edges (the reference's pixels are anti-aliased, the G-buffer's are
  // not; the shadow's edge is 3x3 PCF-filtered) within 5% or 0.005 of the reference.
  int close = 0, lit = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      bool all_close = true;
      for (int c = 0; c < 3; ++c) {
        double d = image.at(x, y, c), r = truth.at(x, y, c);
        all_close = all_close && std::abs(d - r) <= 0.05 * r + 0.005;
      }
      close += all_close;
      lit += truth.at(x, y, 0) > 0.01;
    }
  const double share = double(close) / double(image.pixel_count());
  EXPECT_GT(share, 0.95) << close << " of " << image.pixel_count() << " pixels close";
  EXPECT_GT(lit, int(image.pixel_count() / 2)) << "the floor and box fill most of the view";
}

}  // namespace direct_test
