// A light's power keyframed over time (scene::LightTrack::power): the frame state follows the keys
// with the interpolation of every other track, bad keys are refused naming file:line:col and key,
// and what reads the frame state scales with it: the reference renderer, and the `direct`
// technique through the shared direct-light pass in a run that starts measuring at frames.start.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <glm/gtc/constants.hpp>
#include <map>
#include <string>

#include "photonbench/error.h"
#include "reference/reference.h"
#include "run_fixture.h"
#include "scene/scene.h"

namespace pb::testing {
namespace light_power_test {

// A floor under a point light, one frame a second: its power `power` (a number or keyframes).
std::string scene_text(const std::string& power) {
  return "purpose: a point light whose power is keyframed\n"
         "fps: 1\n"
         "frames: 4\n"
         "camera: {position: [0, 3, 2], target: [0, 0, 0], fov_deg: 50}\n"
         "lights:\n"
         "  - {type: point, position: [0, 2, 0], power: " +
         power +
         "}\n"
         "materials: {floor: {type: diffuse, albedo: 0.5}}\n"
         "objects: [{shape: {type: quad, size: [4, 4]}, material: floor}]\n";
}

scene::Scene parse(const std::string& power) {
  return scene::parse_scene(scene_text(power), "power.yaml");
}

std::string load_error(const std::string& power) {
  try {
    parse(power);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// The light's intensity (W/sr) at frame f.
float intensity(const scene::Scene& scene, uint32_t frame) {
  return scene.at(frame).lights.at(0).radiant.x;
}

constexpr float kFourPi = 4.f * glm::pi<float>();

TEST(LightPower, FollowsItsKeysWithEachInterpolation) {
  // Linear: 40 W at 0 s to 120 W at 2 s, held after the last key.
  scene::Scene linear = parse("{keys: [[0, 40], [2, 120]]}");
  EXPECT_NEAR(intensity(linear, 0) * kFourPi, 40.f, 1e-4f);
  EXPECT_NEAR(intensity(linear, 1) * kFourPi, 80.f, 1e-4f);
  EXPECT_NEAR(intensity(linear, 2) * kFourPi, 120.f, 1e-4f);
  EXPECT_NEAR(intensity(linear, 3) * kFourPi, 120.f, 1e-4f);
  // Step holds the last key reached; a loop wraps by its period (2 s).
  scene::Scene step = parse("{keys: [[0, 40], [2, 120]], interpolation: step, loop: true}");
  EXPECT_NEAR(intensity(step, 1) * kFourPi, 40.f, 1e-4f);
  EXPECT_NEAR(intensity(step, 2) * kFourPi, 40.f, 1e-4f);  // 2 s wraps to 0 s
  EXPECT_NEAR(intensity(step, 3) * kFourPi, 40.f, 1e-4f);
  // Catmull-Rom through 0 W, 100 W, 0 W, 0 W dips below 0 between the last keys: it is clamped
  // there (a light emits no negative power), and passes through the keys.
  scene::Scene spline =
      parse("{keys: [[0, 0], [1, 100], [2, 0], [3, 0]], interpolation: catmull-rom}");
  EXPECT_NEAR(intensity(spline, 1) * kFourPi, 100.f, 1e-4f);
  scene::Keyframes<float> raw = spline.lights[0].power;
  EXPECT_LT(raw.at(2.5f), 0.f);  // the curve itself overshoots
  EXPECT_EQ(spline.lights[0].at(2.5f).radiant, glm::vec3(0.f));
  // The light's colour multiplies the keyed quantity; the loaded light holds time 0's.
  scene::Scene coloured = scene::parse_scene(
      "purpose: t\nfps: 1\nframes: 1\ncamera: {position: [0, 3, 2], target: [0, 0, 0], fov_deg: "
      "50}\n"
      "lights:\n  - {type: quad, position: [0, 2, 0], edge_u: [1, 0, 0], edge_v: [0, 0, 2], "
      "color: [1, 0.5, 0], power: {keys: [[0, 10], [1, 30]]}}\n"
      "materials: {floor: {type: diffuse}}\n"
      "objects: [{shape: {type: quad}, material: floor}]\n",
      "quad.yaml");
  const float pi_area = glm::pi<float>() * 2.f;  // a quad's power is pi L A
  const glm::vec3 at1 = coloured.at(1).lights[0].radiant * pi_area;
  EXPECT_NEAR(at1.x, 30.f, 1e-4f);
  EXPECT_NEAR(at1.y, 15.f, 1e-4f);
  EXPECT_EQ(at1.z, 0.f);
  EXPECT_NEAR(coloured.lights[0].light.radiant.x * pi_area, 10.f, 1e-4f);
  // A constant power is what it was before keyframes existed: 40 W is 40 / 4 pi W/sr at every
  // frame, bit for bit.
  scene::Scene constant = parse("40");
  EXPECT_TRUE(constant.lights[0].power.empty());
  EXPECT_EQ(intensity(constant, 3), 40.f / kFourPi);
}

TEST(LightPower, BadKeysNameFileLineColumnAndKey) {
  std::string e = load_error("{keys: [[0, 40], [2, 120]], interpolaton: linear}");
  EXPECT_NE(e.find("power.yaml:6:"), std::string::npos) << e;
  EXPECT_NE(e.find("lights[0].power.interpolaton: unknown key; did you mean 'interpolation'?"),
            std::string::npos)
      << e;
  e = load_error("{keys: [[1, 40], [1, 120]]}");
  EXPECT_NE(e.find("lights[0].power.keys[1][0]"), std::string::npos) << e;
  EXPECT_NE(e.find("strictly increasing"), std::string::npos) << e;
  e = load_error("{keys: [[0, 40], [1, -5]]}");
  EXPECT_NE(e.find("lights[0].power.keys[1][1]"), std::string::npos) << e;
  e = load_error("{keys: [[0, 40]], loop: true}");
  EXPECT_NE(e.find("lights[0].power.loop: a loop needs at least two keys"), std::string::npos) << e;
  e = load_error("{keys: [[0, 40], [1]]}");
  EXPECT_NE(e.find("lights[0].power.keys[1]"), std::string::npos) << e;
}

// Path tracing draws the same random numbers at every frame of the same seed, and a lone light's
// contributions are linear in its power: the reference at 120 W is 1.5 times the one at 80 W, pixel
// by pixel, up to float rounding.
TEST(LightPower, TheReferenceScalesWithIt) {
  scene::Scene scene = parse("{keys: [[0, 40], [2, 120]]}");
  trace::ReferenceOptions o;
  o.samples = 4;
  o.estimator = trace::Estimator::pt;
  trace::ReferenceImage at80 =
      trace::render_reference(scene, scene.at(1), trace::PathClass::combined, 24, 16, o);
  trace::ReferenceImage at120 =
      trace::render_reference(scene, scene.at(2), trace::PathClass::combined, 24, 16, o);
  double sum = 0;
  for (size_t i = 0; i < at80.mean.pixels.size(); ++i) {
    sum += at80.mean.pixels[i];
    EXPECT_NEAR(at120.mean.pixels[i], 1.5f * at80.mean.pixels[i],
                1e-5f * std::abs(at80.mean.pixels[i]) + 1e-12f)
        << "value " << i;
  }
  EXPECT_GT(sum, 0.0);  // the floor is lit
}

// A run measuring frames 2 and 3 (frames.start 2) with one warm-up frame (1): the `direct`
// technique's frames and their references both scale with the light's power, 80 W at frame 2 and
// 120 W at frame 3; frame 0 never plays and the warm-up frame 1 is not scored.
TEST(LightPower, TheDirectTechniqueScalesWithItFromFramesStart) {
  fs::path dir = work_dir("light_power", "direct");
  fs::path scene_file = dir / "power.yaml";
  std::ofstream(scene_file) << scene_text("{keys: [[1, 40], [3, 120]]}");
  std::string yaml = "name: light-power\nresolution: [24, 16]\nseed: 1\nscenes: [" +
                     scene_file.string() +
                     "]\nframes: {warmup: 1, start: 2, count: 2, metrics_every: 1}\n"
                     "metrics: [psnr]\nlimits: {cell_seconds: 300}\nreference: {samples: 2, "
                     "estimator: pt, cache_dir: " +
                     (dir / "refs").string() + "}\ntechniques: [{technique: direct}]\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << (dir / "log.txt");
  fs::path cell = cell_dir(dir, "power__direct__");
  ASSERT_FALSE(cell.empty());
  for (uint32_t f : {0u, 1u})
    EXPECT_FALSE(fs::exists(cell / "images" / ("frame_000" + std::to_string(f) + ".exr"))) << f;
  io::Image at80 = io::read_image(cell / "images" / "frame_0002.exr");
  io::Image at120 = io::read_image(cell / "images" / "frame_0003.exr");
  ASSERT_EQ(at80.pixels.size(), at120.pixels.size());
  double lit = 0, sum80 = 0, sum120 = 0;
  for (size_t i = 0; i < at80.pixels.size(); i += 4)
    for (int c = 0; c < 3; ++c) {
      sum80 += at80.pixels[i + c], sum120 += at120.pixels[i + c];
      if (at80.pixels[i + c] > 0) {
        ++lit;
        EXPECT_NEAR(at120.pixels[i + c] / at80.pixels[i + c], 1.5, 1e-4) << "pixel " << i / 4;
      }
    }
  EXPECT_GT(lit, 0.5 * at80.pixels.size() * 3 / 4);  // most of the view is the lit floor
  // The run's combined references of the two frames scale alike (by their sidecars).
  std::map<uint32_t, double> reference_sums;
  for (const auto& entry : fs::directory_iterator(dir / "refs")) {
    if (entry.path().extension() != ".json") continue;
    nlohmann::json side = read_json(entry.path());
    if (side["class"] != "combined") continue;
    double s = 0;
    for (float v : io::read_image(dir / "refs" / side["images"]["mean"].get<std::string>()).pixels)
      s += v;
    reference_sums[side["frame"].get<uint32_t>()] = s;
  }
  ASSERT_EQ(reference_sums.size(), 2u) << "one combined reference each for frames 2 and 3";
  EXPECT_GT(reference_sums[2], 0.0);
  EXPECT_NEAR(reference_sums[3] / reference_sums[2], 1.5, 1e-4);
  EXPECT_NEAR(sum120 / sum80, 1.5, 1e-4);
  fs::remove_all(dir);
}

}  // namespace light_power_test
}  // namespace pb::testing
