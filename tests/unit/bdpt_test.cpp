// Bidirectional path tracing (reference/bdpt.h) against path tracing with next-event estimation,
// the anchor, and the automatic choice between them (reference.h, Estimator).
//
// On every shipped scene and every path class the two means agree pixel by pixel within their
// stored variances: a Z-test per pixel-channel against the Sidak-corrected threshold for a
// family-wise 1%, passing for at least 99.75% of them (Mitsuba 3's acceptance). Both run the same
// number of iterations, so that photon mapping, which both use for its part of path space, has the
// same radius schedule and the same blur bias on both sides (its variance does not hold that bias).
// Path tracing needs many iterations on cornell-box before its variance estimate can be trusted:
// it finds the light of the ceiling's hotspot by chance, and with fewer samples most pixels have
// not seen it yet (their mean and variance both too low, failing the test where bidirectional path
// tracing is right; measured: 24 of 270 pixel-channels fail at 2048 iterations, none at 16384).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "metrics/z_test.h"
#include "reference/reference.h"
#include "scene/scene.h"
#include "test_scenes.h"
#include "trace/embree_scene.h"

namespace pb::trace {
namespace bdpt_test {

struct SceneCase {
  std::string name;
  uint32_t iterations, pt_iterations;
};
// How CTest and GoogleTest print the case (`-N`, failures): its scene and iteration counts, not
// the struct's bytes.
void PrintTo(const SceneCase& c, std::ostream* out) {
  *out << c.name << " (BDPT " << c.iterations << ", path tracing " << c.pt_iterations
       << " iterations)";
}

class EstimatorsAgree : public ::testing::TestWithParam<SceneCase> {};

TEST_P(EstimatorsAgree, OnEveryClassPixelByPixel) {
  const SceneCase& param = GetParam();
  scene::Scene scene =
      scene::load_scene(std::filesystem::path(PB_SOURCE_DIR) / "scenes" / (param.name + ".yaml"));
  EmbreeScene world(scene, scene.at(4));  // quick.yaml's first metric frame
  ReferenceOptions o;
  o.samples = param.pt_iterations;
  o.photon_mapping.photons = 1000;
  o.estimator = Estimator::pt;
  o.seed = 5;
  ReferenceResult pt = render_reference_classes(world, 16, 9, kAllPathClasses, o);
  o.samples = param.iterations;
  o.estimator = Estimator::bdpt;
  o.seed = 6;
  ReferenceResult bd = render_reference_classes(world, 16, 9, kAllPathClasses, o);
  for (PathClass c : all_path_classes()) {
    const ReferenceImage& a = pt.classes[int(c)];
    const ReferenceImage& b = bd.classes[int(c)];
    const metrics::ZTestResult z = metrics::z_test(a.mean, a.variance, b.mean, b.variance);
    std::printf("%s %s: %zu of %zu pixel-channels beyond the Sidak level %.3g\n",
                param.name.c_str(), std::string(path_class_name(c)).c_str(), z.rejected,
                z.tested - z.exact, z.sidak_level);
    EXPECT_LE(z.rejected_share_with_variance(), 0.0025) << path_class_name(c);
    EXPECT_EQ(z.exact_mismatches, 0u) << path_class_name(c);
  }
}

INSTANTIATE_TEST_SUITE_P(
    ShippedScenes, EstimatorsAgree,
    ::testing::Values(SceneCase{"cornell-box", 4096, 65536}, SceneCase{"cornell-glass", 2048, 2048},
                      SceneCase{"dynamic-room", 2048, 2048}, SceneCase{"mirror-box", 2048, 2048},
                      SceneCase{"pillars", 2048, 2048}, SceneCase{"pool", 2048, 2048},
                      SceneCase{"ring", 2048, 2048}, SceneCase{"torus-in-glass-cube", 2048, 2048},
                      SceneCase{"merry-go-round", 2048, 2048}, SceneCase{"walker", 2048, 2048},
                      SceneCase{"villa", 2048, 2048}, SceneCase{"pool-underwater", 2048, 2048},
                      SceneCase{"square", 2048, 2048}, SceneCase{"cornell-spot", 2048, 2048},
                      SceneCase{"spot-window", 2048, 2048}, SceneCase{"slats", 2048, 2048},
                      SceneCase{"wall", 2048, 2048}),
    [](const ::testing::TestParamInfo<SceneCase>& info) {
      std::string s = info.param.name;
      for (char& ch : s)
        if (ch == '-') ch = '_';
      return s;
    });

// A floor lit only by a ceiling that a quad light (facing up, 0.3 m under it) lights: the floor's
// light is all indirect (C D D L and longer), and no two surfaces touch, so every strategy has a
// finite variance. Bidirectional path tracing with the power heuristic and with uniform weights
// (where light tracing and the connections carry a third or more of the floor) agree with path
// tracing pixel by pixel.
TEST(BidirectionalStrategies, EachCarriesItsShareOfIndirectLight) {
  using namespace test_scenes;
  TestScene t;
  uint32_t white = t.material(scene::MaterialType::diffuse, glm::vec3(0.7f));
  t.object(quad_mesh({-2, 0, 2}, {4, 0, 0}, {0, 0, -4}), white);     // floor, facing up
  t.object(quad_mesh({-2, 1.3f, -2}, {4, 0, 0}, {0, 0, 4}), white);  // ceiling, facing down
  scene::Light light;
  light.type = scene::LightType::quad;
  light.position = {-0.25f, 1.f, -0.25f};
  light.edge_u = {0, 0, 0.5f};  // cross(edge_u, edge_v) = +y: towards the ceiling
  light.edge_v = {0.5f, 0, 0};
  light.radiant = glm::vec3(20.f);
  t.light(light);
  t.camera({0, 0.6f, 1.2f}, {0, 0, 0}, {0, 1, 0}, 60.f);
  ReferenceOptions o;
  o.samples = 32768;  // path tracing's hotspot on the ceiling needs many (cheap) samples
  o.estimator = Estimator::pt;
  o.seed = 3;
  ReferenceImage pt = render_reference(t.scene, t.state, PathClass::indirect, 16, 9, o);
  for (MisHeuristic h : {MisHeuristic::power, MisHeuristic::uniform}) {
    o.estimator = Estimator::bdpt;
    o.samples = 4096;
    o.mis_heuristic = h;
    o.seed = 4 + int(h);
    ReferenceImage bd = render_reference(t.scene, t.state, PathClass::indirect, 16, 9, o);
    const metrics::ZTestResult z = metrics::z_test(pt.mean, pt.variance, bd.mean, bd.variance);
    double sum_pt = 0, sum_bd = 0, var = 0;
    for (size_t i = 0; i < pt.mean.pixels.size(); ++i) {
      sum_pt += pt.mean.pixels[i], sum_bd += bd.mean.pixels[i];
      var += double(pt.variance.pixels[i]) + bd.variance.pixels[i];
    }
    std::printf("%s: %zu of %zu beyond the Sidak level %.3g; image sums %.4f vs %.4f (z %.2f)\n",
                h == MisHeuristic::power ? "power" : "uniform", z.rejected, z.tested - z.exact,
                z.sidak_level, sum_pt, sum_bd, (sum_pt - sum_bd) / std::sqrt(var));
    EXPECT_LE(z.rejected_share_with_variance(), 0.0025);
    EXPECT_GT(z.tested - z.exact, 300u);
    // The floor's pixels are independent for path tracing, not quite for light tracing (one light
    // path splats into several pixels): a loose bound on the image sums.
    EXPECT_LT(std::abs(sum_pt - sum_bd) / std::sqrt(var), 5.0);
  }
}

// The automatic choice renders exactly what the estimator it chose renders with the same seed (the
// render starts as path tracing and restarts when the pilot picks bidirectional path tracing), and
// it chooses bidirectional path tracing where path tracing struggles (cornell-box's hotspot) and
// path tracing where the sun does the work (pillars). On cornell-box at a target looser than 0.1,
// path tracing's own error estimate, which misses the hotspot, reaches it before the pilot can
// tell.
TEST(AutomaticEstimator, PicksPerSceneAndRendersAsThePickedOne) {
  struct Case {
    const char* name;
    float rel_error;
    Estimator expected;
  };
  for (const auto& [name, rel_error, expected] :
       {Case{"cornell-box", 0.1f, Estimator::bdpt}, Case{"pillars", 0.2f, Estimator::pt}}) {
    scene::Scene scene = scene::load_scene(std::filesystem::path(PB_SOURCE_DIR) / "scenes" /
                                           (std::string(name) + ".yaml"));
    EmbreeScene world(scene, scene.at(4));
    ReferenceOptions o;
    o.rel_error = rel_error;
    o.samples = 256;
    uint32_t mask = class_bit(PathClass::combined) | class_bit(PathClass::indirect);
    ReferenceResult chosen = render_reference_classes(world, 240, 135, mask, o);
    EXPECT_TRUE(chosen.pilot.ran);
    EXPECT_EQ(chosen.estimator, expected) << name;
    EXPECT_EQ(chosen.classes[int(PathClass::combined)].estimator, expected);
    o.estimator = expected;
    ReferenceResult plain = render_reference_classes(world, 240, 135, mask, o);
    EXPECT_FALSE(plain.pilot.ran);
    EXPECT_EQ(chosen.image(PathClass::combined).pixels, plain.image(PathClass::combined).pixels);
    EXPECT_EQ(chosen.samples, plain.samples);
    std::printf("%s: pilot error^2 per iteration %.3f (pt) %.3f (bdpt), rays %.0f / %.0f\n", name,
                chosen.pilot.pt_error2, chosen.pilot.bdpt_error2, chosen.pilot.pt_rays,
                chosen.pilot.bdpt_rays);
  }
}

// The pilot decides whatever the stop rule: a render asked for a fixed number of samples (no error
// target) is piloted too, renders as the estimator it picked, and says why.
TEST(AutomaticEstimator, PilotsARenderOfAFixedNumberOfSamples) {
  scene::Scene scene =
      scene::load_scene(std::filesystem::path(PB_SOURCE_DIR) / "scenes" / "cornell-box.yaml");
  EmbreeScene world(scene, scene.at(4));
  ReferenceOptions o;
  o.rel_error = 0;
  o.samples = 48;
  uint32_t mask = class_bit(PathClass::combined);
  ReferenceResult chosen = render_reference_classes(world, 240, 135, mask, o);
  ASSERT_TRUE(chosen.pilot.ran);
  EXPECT_GT(chosen.pilot.iterations, 0u);
  EXPECT_FALSE(chosen.pilot.why.empty());
  EXPECT_EQ(chosen.samples, 48u);
  o.estimator = chosen.estimator;
  ReferenceResult plain = render_reference_classes(world, 240, 135, mask, o);
  EXPECT_FALSE(plain.pilot.ran);
  EXPECT_EQ(plain.pilot.why, "asked for");
  EXPECT_EQ(chosen.image(PathClass::combined).pixels, plain.image(PathClass::combined).pixels);
  std::printf("cornell-box, 48 samples: %s (%s); pilot %u bidirectional iterations\n",
              std::string(estimator_name(chosen.estimator)).c_str(), chosen.pilot.why.c_str(),
              chosen.pilot.bdpt_iterations);
}

// The pilot's cost scales with the render: it spends nothing where bidirectional path tracing
// cannot win whatever its variance. On ring at a loose target path tracing stops at its least
// iterations, and bidirectional path tracing's least cost is above that.
TEST(AutomaticEstimator, PilotSpendsAShareOfTheRender) {
  scene::Scene scene =
      scene::load_scene(std::filesystem::path(PB_SOURCE_DIR) / "scenes" / "ring.yaml");
  EmbreeScene world(scene, scene.at(4));
  ReferenceOptions o;
  o.rel_error = 0.2f;
  o.samples = 0;
  o.max_seconds = 60;
  uint32_t mask = class_bit(PathClass::combined);
  ReferenceResult r = render_reference_classes(world, 240, 135, mask, o);
  ASSERT_TRUE(r.pilot.ran);
  EXPECT_EQ(r.estimator, Estimator::pt);
  EXPECT_EQ(r.pilot.dropped_iterations, 0u);
  EXPECT_LE(r.pilot.iterations, r.samples);
  EXPECT_EQ(r.pilot.bdpt_iterations, 0u);
  EXPECT_EQ(r.pilot.pilot_rays, 0.0);
  std::printf(
      "ring: %u render iterations, pilot %u bidirectional iterations, %.0f rays (%.2f%% of "
      "the render's %.0f)\n",
      r.samples, r.pilot.bdpt_iterations, r.pilot.pilot_rays,
      100.0 * r.pilot.pilot_rays / double(r.rays), double(r.rays));
}

}  // namespace bdpt_test
}  // namespace pb::trace
