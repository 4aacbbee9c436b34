// The reference renderer (src/reference/reference.h): analytic images first (camera model, white
// furnace, a point light over a plane, a caustic through a flat mirror), then the statistics of
// convergence (path tracing at samples^-1/2, photon mapping's caustics converging), the
// path-class partition and the cache.
#include "reference/reference.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include "photonbench/error.h"
#include "test_scenes.h"
#include "trace/embree_scene.h"
#include "trace/sampling.h"

namespace pb::trace {
namespace reference_test {

using namespace test_scenes;

scene::Scene load(const char* name) {
  return scene::load_scene(std::filesystem::path(PB_SOURCE_DIR) / "scenes" / name);
}

double mean_channel(const io::Image& img, int c) {
  double s = 0;
  for (size_t i = 0; i < img.pixel_count(); ++i) s += img.pixels[i * img.channels + c];
  return s / img.pixel_count();
}

// relMSE with a floor of 1% of the mean squared reference, so black pixels do not dominate.
double rel_mse(const io::Image& x, const io::Image& ref) {
  double mean2 = 0;
  for (float v : ref.pixels) mean2 += double(v) * v;
  mean2 /= ref.pixels.size();
  double acc = 0;
  for (size_t i = 0; i < ref.pixels.size(); ++i) {
    double d = double(x.pixels[i]) - ref.pixels[i];
    acc += d * d / (double(ref.pixels[i]) * ref.pixels[i] + 0.01 * mean2);
  }
  return acc / ref.pixels.size();
}

double rmse(const io::Image& x, const io::Image& ref) {
  double acc = 0;
  for (size_t i = 0; i < ref.pixels.size(); ++i)
    acc += std::pow(double(x.pixels[i]) - ref.pixels[i], 2.0);
  return std::sqrt(acc / ref.pixels.size());
}

// ---- camera
// ----------------------------------------------------------------------------------------

// A point along the ray through pixel position (px, py) projects back to (px, py) with the
// harness's Camera::view / projection (Vulkan clip space, y down): references and rasterised
// techniques see the same pixels.
TEST(Reference, CameraRaysMatchViewAndProjection) {
  scene::Camera cam;
  cam.position = {0.3f, 1.2f, 2.5f};
  cam.target = {0.1f, 0.4f, -0.2f};
  cam.up = {0, 1, 0};
  cam.fov_y = glm::radians(50.f);
  const int w = 160, h = 90;
  glm::mat4 clip_from_world = cam.projection(float(w) / h) * cam.view();
  for (glm::vec2 p : {glm::vec2(0.5f, 0.5f), glm::vec2(159.5f, 0.5f), glm::vec2(80, 45),
                      glm::vec2(12.25f, 77.5f)}) {
    CameraRay ray = camera_ray(cam, w, h, p.x, p.y);
    glm::vec4 clip = clip_from_world * glm::vec4(ray.origin + 3.f * ray.direction, 1.f);
    glm::vec2 ndc = glm::vec2(clip) / clip.w;
    EXPECT_NEAR((ndc.x + 1) * 0.5f * w, p.x, 1e-3f);
    EXPECT_NEAR((ndc.y + 1) * 0.5f * h, p.y, 1e-3f);
  }
}

// ---- analytic images
// -------------------------------------------------------------------------------

ReferenceOptions quick(uint32_t samples) {
  ReferenceOptions o;
  o.samples = samples;
  o.photon_mapping.photons = 20000;
  return o;
}

io::Image render_mean(const TestScene& t, PathClass c, int w, int h, const ReferenceOptions& o) {
  return render_reference(t.scene, t.state, c, w, h, o).mean;
}

// The closed-form tests run with each unbiased estimator: path tracing, and bidirectional path
// tracing (whose connections and light tracing carry part of a furnace's interreflections; with
// uniform MIS weights they would carry more, but a box's edges, where two walls meet, make the
// connections' 1 / d^2 a heavy-tailed estimate: bdpt_test checks the strategies' shares on a scene
// without touching surfaces instead).
struct EstimatorCase {
  Estimator estimator;
  MisHeuristic heuristic;
  const char* name;
};
void PrintTo(const EstimatorCase& c, std::ostream* out) { *out << c.name; }
class ReferenceByEstimator : public ::testing::TestWithParam<EstimatorCase> {
 protected:
  ReferenceOptions quick(uint32_t samples) const {
    ReferenceOptions o = reference_test::quick(samples);
    o.estimator = GetParam().estimator;
    o.mis_heuristic = GetParam().heuristic;
    return o;
  }
};
INSTANTIATE_TEST_SUITE_P(Estimators, ReferenceByEstimator,
                         ::testing::Values(EstimatorCase{Estimator::pt, MisHeuristic::power, "pt"},
                                           EstimatorCase{Estimator::bdpt, MisHeuristic::power,
                                                         "bdpt"}),
                         [](const ::testing::TestParamInfo<EstimatorCase>& info) {
                           return std::string(info.param.name);
                         });

// A white (albedo 1) diffuse ball inside a closed enclosure whose walls emit L = 1 and reflect
// nothing: the ball reflects exactly what it receives, so every pixel shows radiance 1 (the "white
// furnace").
TEST_P(ReferenceByEstimator, WhiteFurnaceBallInUniformEmitterIsInvisible) {
  TestScene t;
  t.object(box_mesh({-2, -2, -2}, {2, 2, 2}, true),
           t.material(scene::MaterialType::emissive, glm::vec3(0.f), glm::vec3(1.f)));
  t.object(sphere_mesh({0, 0, 0}, 0.6f, 48),
           t.material(scene::MaterialType::diffuse, glm::vec3(1.f)));
  t.camera({0, 0.2f, 1.8f}, {0, 0, 0}, {0, 1, 0}, 50.f);
  // Few pixels, many samples: the per-sample spread of NEE + MIS here is about 0.3.
  io::Image img = render_mean(t, PathClass::combined, 8, 8, quick(32768));
  double worst = 0;
  for (float v : img.pixels) worst = std::max(worst, std::abs(v - 1.0));
  EXPECT_LT(worst, 0.01);
  EXPECT_NEAR(mean_channel(img, 1), 1.0, 0.002);
}

// A closed enclosure of diffuse emitters with albedo 1/2 and L_e = 1: L = L_e + a L, so L = 2
// everywhere (all interreflections, Russian roulette included).
TEST_P(ReferenceByEstimator, WhiteFurnaceEmittingEnclosureReachesTheNeumannSum) {
  TestScene t;
  t.object(box_mesh({-1, -1, -1}, {1, 1, 1}, true),
           t.material(scene::MaterialType::emissive, glm::vec3(0.5f), glm::vec3(1.f)));
  t.camera({0.2f, 0.1f, 0.5f}, {0, 0, -1}, {0, 1, 0}, 70.f);
  io::Image img = render_mean(t, PathClass::combined, 8, 8, quick(32768));
  double worst = 0;
  for (float v : img.pixels) worst = std::max(worst, std::abs(v / 2.0 - 1.0));
  EXPECT_LT(worst, 0.01);
  EXPECT_NEAR(mean_channel(img, 0), 2.0, 0.004);
}

// max_bounces counts scattering vertices on a full path: in the emitting enclosure above, paths
// with k vertices carry a^k L_e, so a render truncated at B reads sum_{k <= B} a^k (1, 1.5, 1.75,
// ...).
TEST_P(ReferenceByEstimator, MaxBouncesTruncatesAtThatManyScatteringVertices) {
  TestScene t;
  t.object(box_mesh({-1, -1, -1}, {1, 1, 1}, true),
           t.material(scene::MaterialType::emissive, glm::vec3(0.5f), glm::vec3(1.f)));
  t.camera({0.2f, 0.1f, 0.5f}, {0, 0, -1}, {0, 1, 0}, 70.f);
  for (uint32_t bounces : {1u, 2u, 3u}) {
    ReferenceOptions o = quick(4096);
    o.max_bounces = bounces;
    io::Image img = render_mean(t, PathClass::combined, 4, 4, o);
    double expected = 2.0 - std::pow(0.5, double(bounces));
    EXPECT_NEAR(mean_channel(img, 0) / expected, 1.0, 0.004) << bounces << " bounces";
  }
  EXPECT_EQ(bounces_matching_photon_technique(4), 4u);
}

// A point light of intensity I at height h over a Lambertian plane of albedo a: L = a / pi * I cos
// / r^2 at every point. Checked on a row of pixels against the analytic value averaged over each
// pixel.
TEST_P(ReferenceByEstimator, PointLightOverPlaneMatchesInverseSquareCosineLaw) {
  TestScene t;
  const float albedo = 0.6f, intensity = 2.f;
  const glm::vec3 light{0.3f, 1.f, -0.2f};
  t.object(quad_mesh({-5, 0, 5}, {10, 0, 0}, {0, 0, -10}),
           t.material(scene::MaterialType::diffuse, glm::vec3(albedo)));
  t.point_light(light, intensity);
  t.camera({0, 2, 0.01f}, {0, 0, 0}, {0, 0, -1}, 60.f);
  const int w = 48, h = 32;
  io::Image img = render_mean(t, PathClass::direct, w, h, quick(64));
  io::Image combined = render_mean(t, PathClass::combined, w, h, quick(64));
  int y = 13;
  for (int x = 0; x < w; ++x) {
    double expected = 0;
    for (int sy = 0; sy < 4; ++sy)
      for (int sx = 0; sx < 4; ++sx) {
        CameraRay r = camera_ray(t.state.camera, w, h, x + (sx + 0.5f) / 4, y + (sy + 0.5f) / 4);
        glm::vec3 p = r.origin + r.direction * (-r.origin.y / r.direction.y);
        glm::vec3 d = light - p;
        double r2 = glm::dot(d, d);
        expected += albedo / M_PI * intensity * (d.y / std::sqrt(r2)) / r2 / 16;
      }
    EXPECT_NEAR(img.at(x, y, 0) / expected, 1.0, 0.01) << "x " << x;
    EXPECT_NEAR(combined.at(x, y, 2) / expected, 1.0, 0.01) << "x " << x;  // nothing else lights it
  }
}

// Point light between a horizontal mirror and a diffuse ceiling: the ceiling's caustic (C D S L) is
// the light of the mirror image of the source, a / pi * I cos / r^2 with r from the image below the
// mirror. Only photons reach it (a point light seen through a perfect mirror), so this checks
// photon mapping end to end.
TEST(Reference, MirrorCausticMatchesTheImageSource) {
  TestScene t;
  const float albedo = 0.8f, intensity = 1.f;
  t.object(quad_mesh({-4, 1, -4}, {8, 0, 0}, {0, 0, 8}),
           t.material(scene::MaterialType::diffuse, glm::vec3(albedo)));
  t.object(quad_mesh({-6, 0, 6}, {12, 0, 0}, {0, 0, -12}),
           t.material(scene::MaterialType::mirror, glm::vec3(0.f)));
  t.point_light({0, 0.4f, 0}, intensity);
  t.camera({0, 0.8f, 0.01f}, {0, 1, 0}, {0, 0, -1}, 90.f);
  const int w = 32, h = 24;
  ReferenceOptions o = quick(64);
  o.photon_mapping.photons = 100000;
  // The caustic is smooth here (its source is 1.4 m away): blur bias < 1%.
  o.photon_mapping.radius = 0.1f;
  EmbreeScene world(t.scene, t.state);
  ReferenceResult r = render_reference_classes(
      world, w, h, class_bit(PathClass::caustics) | class_bit(PathClass::direct), o);
  const io::Image& caustic = r.image(PathClass::caustics);
  const io::Image& direct = r.image(PathClass::direct);
  const glm::vec3 image_source{0, -0.4f, 0}, source{0, 0.4f, 0};
  double worst = 0;
  for (int y = 4; y < h - 4; y += 3)
    for (int x = 4; x < w - 4; ++x) {
      CameraRay ray = camera_ray(t.state.camera, w, h, x + 0.5f, y + 0.5f);
      glm::vec3 p = ray.origin + ray.direction * ((1 - ray.origin.y) / ray.direction.y);
      auto law = [&](glm::vec3 s) {
        glm::vec3 d = s - p;
        double r2 = glm::dot(d, d);
        return albedo / M_PI * intensity * (-d.y / std::sqrt(r2)) / r2;
      };
      worst = std::max(worst, std::abs(caustic.at(x, y, 0) / law(image_source) - 1.0));
      EXPECT_NEAR(direct.at(x, y, 0) / law(source), 1.0, 0.01);
    }
  EXPECT_LT(worst, 0.04);  // density estimation noise (about 2% here) and the blur of the radius
  EXPECT_EQ(r.samples, 64u);
  EXPECT_GT(r.photon_paths, 0u);
  RecordProperty("worst", std::to_string(worst));
}

// ---- convergence
// -----------------------------------------------------------------------------------

// Path tracing is unbiased with independent samples: RMSE against a 16x longer render of another
// seed falls as samples^-1/2 (log-log slope in [-0.6, -0.4]).
TEST(Reference, PathTracerRmseFallsAsInverseSquareRootOfSamples) {
  scene::Scene scene = load("cornell-box.yaml");
  scene::FrameState state = scene.at(0);
  EmbreeScene world(scene, state);
  const int w = 32, h = 24;
  ReferenceOptions o;
  o.seed = 99;
  o.samples = 2048;
  io::Image ref = render_reference_classes(world, w, h, class_bit(PathClass::combined), o)
                      .image(PathClass::combined);
  std::vector<double> xs, ys;
  for (uint32_t spp : {8u, 32u, 128u}) {
    o.seed = 1;
    o.samples = spp;
    io::Image img = render_reference_classes(world, w, h, class_bit(PathClass::combined), o)
                        .image(PathClass::combined);
    xs.push_back(std::log(double(spp)));
    ys.push_back(std::log(rmse(img, ref)));
  }
  double mx = (xs[0] + xs[1] + xs[2]) / 3, my = (ys[0] + ys[1] + ys[2]) / 3, sxy = 0, sxx = 0;
  for (int i = 0; i < 3; ++i)
    sxy += (xs[i] - mx) * (ys[i] - my), sxx += (xs[i] - mx) * (xs[i] - mx);
  double slope = sxy / sxx;
  EXPECT_GE(slope, -0.6);
  EXPECT_LE(slope, -0.4);
  RecordProperty("slope", std::to_string(slope));
}

// Photon mapping's caustic image on cornell-glass gets closer to a long render with every step in
// iterations.
TEST(Reference, PhotonMappingCausticRelMseDecreasesOverIterations) {
  scene::Scene scene = load("cornell-glass.yaml");
  scene::FrameState state = scene.at(0);
  EmbreeScene world(scene, state);
  const int w = 32, h = 24;
  ReferenceOptions o = quick(400);
  o.seed = 7;
  io::Image ref = render_reference_classes(world, w, h, class_bit(PathClass::caustics), o)
                      .image(PathClass::caustics);
  ASSERT_GT(mean_channel(ref, 0), 0.0);
  double previous = 1e30;
  for (uint32_t iterations : {4u, 16u, 64u}) {
    o.seed = 1;
    o.samples = iterations;
    io::Image img = render_reference_classes(world, w, h, class_bit(PathClass::caustics), o)
                        .image(PathClass::caustics);
    double e = rel_mse(img, ref);
    EXPECT_LT(e, previous) << iterations << " iterations";
    previous = e;
  }
}

// ---- mean, variance and halves ---------------------------------------------------------------

// Mean over pixel-channels of (a - b)^2 / (var_a + var_b): about 1 when the stored variances are
// the variances of the means (independent renders of the same expectation).
double mean_squared_z(const io::Image& a, const io::Image& va, const io::Image& b,
                      const io::Image& vb, size_t* counted = nullptr) {
  double acc = 0;
  size_t n = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    double v = double(va.pixels[i]) + vb.pixels[i];
    if (!(v > 0)) continue;
    double d = double(a.pixels[i]) - b.pixels[i];
    acc += d * d / v;
    ++n;
  }
  if (counted) *counted = n;
  return n ? acc / double(n) : 0.0;
}

// The stored variance is the variance of the mean, for the path-traced and the photon-mapped part
// alike: two renders with other seeds differ by as much as their variances say, and so do the two
// halves of one render (each of n/2 iterations: var(half0 - half1) = 4 var(mean)).
TEST(Reference, VarianceOfTheMeanMatchesTheSpreadOfIndependentRenders) {
  scene::Scene scene = load("cornell-glass.yaml");
  EmbreeScene world(scene, scene.at(0));
  ReferenceOptions o = quick(64);
  uint32_t mask = class_bit(PathClass::combined) | class_bit(PathClass::caustics) |
                  class_bit(PathClass::direct);
  o.seed = 11;
  ReferenceResult a = render_reference_classes(world, 24, 18, mask, o);
  o.seed = 12;
  ReferenceResult b = render_reference_classes(world, 24, 18, mask, o);
  for (PathClass c : {PathClass::combined, PathClass::caustics, PathClass::direct}) {
    const ReferenceImage& x = a.classes[int(c)];
    const ReferenceImage& y = b.classes[int(c)];
    size_t n = 0;
    double z2 = mean_squared_z(x.mean, x.variance, y.mean, y.variance, &n);
    EXPECT_GT(n, 300u) << path_class_name(c);
    EXPECT_GT(z2, 0.75) << path_class_name(c);
    EXPECT_LT(z2, 1.33) << path_class_name(c);
    io::Image four_var = x.variance;
    for (float& v : four_var.pixels) v *= 2;  // halves: var(h0 - h1) = 4 var = 2 var + 2 var
    double halves = mean_squared_z(x.half[0], four_var, x.half[1], four_var);
    EXPECT_GT(halves, 0.75) << path_class_name(c);
    EXPECT_LT(halves, 1.33) << path_class_name(c);
    for (size_t i = 0; i < x.mean.pixels.size(); ++i)
      ASSERT_NEAR(x.mean.pixels[i], 0.5 * (x.half[0].pixels[i] + x.half[1].pixels[i]),
                  1e-5 * (1 + x.mean.pixels[i]));
    RecordProperty(std::string(path_class_name(c)) + "_z2", std::to_string(z2));
  }
}

// Stop rules: the first reached ends the render and says so; the error and time rules stop on even
// counts.
TEST(Reference, StopsAtTheFirstRuleReachedAndSaysWhich) {
  scene::Scene scene = load("cornell-box.yaml");
  EmbreeScene world(scene, scene.at(0));
  uint32_t mask = class_bit(PathClass::combined);
  ReferenceOptions o;
  o.samples = 512;
  o.rel_error = 0.3f;
  o.min_samples = 4;
  ReferenceResult by_error = render_reference_classes(world, 16, 12, mask, o);
  EXPECT_EQ(by_error.stopped_by, StopRule::rel_error);
  EXPECT_LE(by_error.rel_error, 0.3);
  EXPECT_GT(by_error.rel_error, 0.0);
  EXPECT_EQ(by_error.samples % 2, 0u);
  EXPECT_LT(by_error.samples, 512u);
  o.rel_error = 1e-4f;
  o.samples = 6;
  ReferenceResult by_samples = render_reference_classes(world, 16, 12, mask, o);
  EXPECT_EQ(by_samples.stopped_by, StopRule::samples);
  EXPECT_EQ(by_samples.samples, 6u);
  EXPECT_GT(by_samples.rel_error, 1e-4);
  o.samples = 0;
  o.max_seconds = 1e-9;
  ReferenceResult by_time = render_reference_classes(world, 16, 12, mask, o);
  EXPECT_EQ(by_time.stopped_by, StopRule::max_seconds);
  EXPECT_EQ(by_time.samples, 2u);
  EXPECT_EQ(by_time.classes[int(PathClass::combined)].stopped_by, StopRule::max_seconds);
  o.max_seconds = 0;
  o.rel_error = 0;
  EXPECT_THROW(render_reference_classes(world, 16, 12, mask, o), InputError);
}

// The same seed gives the same reference, bit for bit, whatever the number of threads.
TEST(Reference, DeterministicForAGivenSeedWhateverTheThreadCount) {
  scene::Scene scene = load("cornell-glass.yaml");
  EmbreeScene world(scene, scene.at(3));
  ReferenceOptions o = quick(6);
  o.threads = 1;
  ReferenceResult one = render_reference_classes(world, 20, 14, kAllPathClasses, o);
  o.threads = 3;
  ReferenceResult three = render_reference_classes(world, 20, 14, kAllPathClasses, o);
  for (int c = 0; c < kPathClassCount; ++c) {
    EXPECT_EQ(one.classes[c].mean.pixels, three.classes[c].mean.pixels) << c;
    EXPECT_EQ(one.classes[c].variance.pixels, three.classes[c].variance.pixels) << c;
    EXPECT_EQ(one.classes[c].half[1].pixels, three.classes[c].half[1].pixels) << c;
  }
}

// ---- path classes
// ----------------------------------------------------------------------------------

TEST(Reference, PathClassesPartitionTheImage) {
  EXPECT_EQ(parse_path_class("indirect_caustics"), PathClass::indirect_caustics);
  EXPECT_FALSE(parse_path_class("caustic").has_value());
  EXPECT_EQ(path_class_expression(PathClass::caustics), "C D S+ L");
  scene::Scene scene = load("cornell-glass.yaml");
  EmbreeScene world(scene, scene.at(0));
  ReferenceResult r = render_reference_classes(world, 24, 18, kAllPathClasses, quick(16));
  const io::Image& combined = r.image(PathClass::combined);
  double class_energy[5] = {};
  for (size_t i = 0; i < combined.pixels.size(); ++i) {
    double sum = 0;
    for (int c = 0; c < 5; ++c) {
      float v = r.classes[c].mean.pixels[i];
      ASSERT_GE(v, 0.f);
      sum += v;
      class_energy[c] += v;
    }
    ASSERT_NEAR(sum, combined.pixels[i], 1e-5 * (1 + sum));
  }
  for (int c = 0; c < 5; ++c) EXPECT_GT(class_energy[c], 0.0) << path_class_name(PathClass(c));
  // Without specular surfaces the specular-involving classes are exactly empty.
  scene::Scene box = load("cornell-box.yaml");
  EmbreeScene box_world(box, box.at(0));
  ReferenceResult b = render_reference_classes(box_world, 16, 12, kAllPathClasses, quick(4));
  for (PathClass c : {PathClass::caustics, PathClass::indirect_caustics, PathClass::specular})
    EXPECT_EQ(mean_channel(b.image(c), 0), 0.0) << path_class_name(c);
  EXPECT_EQ(b.photon_paths, 0u);
}

// ---- cache
// -----------------------------------------------------------------------------------------

// A class no path of the scene belongs to (caustics in the all-diffuse Cornell box) renders black:
// its error estimate is 0 at the first check, and the entry stopped by the error rule must serve
// that rule afterwards. It was once refused (an error of 0 read as "not measured"), so every run
// rendered it again and then failed with "the entry just written cannot be read back".
TEST(ReferenceCache, ServesABlackReferenceStoppedByTheErrorRule) {
  auto dir = std::filesystem::path(::testing::TempDir()) /
             ("pb_reference_cache_black_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  scene::Scene scene = load("cornell-box.yaml");
  ReferenceCache cache(dir);
  ReferenceOptions o = quick(0);
  o.rel_error = 0.05f;
  o.max_seconds = 60;
  io::Image black = cache.get_or_render(scene, scene.at(0), PathClass::caustics, 16, 12, o);
  for (float v : black.pixels) ASSERT_EQ(v, 0.0f);
  std::optional<ReferenceImage> entry =
      cache.get_entry(scene, scene.at(0), PathClass::caustics, 16, 12, o);
  ASSERT_TRUE(entry.has_value());
  EXPECT_EQ(entry->stopped_by, StopRule::rel_error);
  EXPECT_TRUE(cache.has(scene, scene.at(0), PathClass::caustics, 16, 12, o));
  std::filesystem::remove_all(dir);
}

TEST(ReferenceCache, StoresAtomicallyAndReusesByContent) {
  auto dir = std::filesystem::path(::testing::TempDir()) /
             ("pb_reference_cache_test_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  scene::Scene scene = load("cornell-box.yaml");
  ReferenceCache cache(dir);
  ReferenceOptions o = quick(4);
  scene::FrameState f0 = scene.at(0), f1 = scene.at(1);
  std::string k = cache.key(scene, f0, PathClass::direct, 16, 12, o);
  EXPECT_EQ(k, cache.key(scene, scene.at(0), PathClass::direct, 16, 12, o));
  EXPECT_NE(k, cache.key(scene, f1, PathClass::direct, 16, 12, o));
  EXPECT_NE(k, cache.key(scene, f0, PathClass::combined, 16, 12, o));
  EXPECT_NE(k, cache.key(scene, f0, PathClass::direct, 16, 13, o));
  EXPECT_FALSE(cache.has(scene, f0, PathClass::direct, 16, 12, o));

  io::Image a = cache.get_or_render(scene, f0, PathClass::direct, 16, 12, o);
  EXPECT_TRUE(cache.has(scene, f0, PathClass::direct, 16, 12, o));
  std::ifstream side(dir / (k + ".json"));
  nlohmann::json j = nlohmann::json::parse(side);
  EXPECT_EQ(j["samples"], 4);
  EXPECT_EQ(j["class"], "direct");
  EXPECT_EQ(j["frame"], 0);
  EXPECT_EQ(j["scene"], "cornell-box");
  io::Image b = cache.get_or_render(scene, f0, PathClass::direct, 16, 12, o);
  EXPECT_EQ(a.pixels, b.pixels);
  // The whole entry comes back: mean, variance, halves and the sidecar's fields.
  std::optional<ReferenceImage> entry = cache.get_entry(scene, f0, PathClass::direct, 16, 12, o);
  ASSERT_TRUE(entry.has_value());
  EXPECT_EQ(entry->mean.pixels, a.pixels);
  EXPECT_EQ(entry->samples, 4u);
  EXPECT_EQ(entry->stopped_by, StopRule::samples);
  EXPECT_EQ(j["stopped_by"], "samples");
  EXPECT_EQ(entry->variance.pixels.size(), a.pixels.size());
  EXPECT_GT(mean_channel(entry->variance, 0), 0.0);
  for (size_t i = 0; i < a.pixels.size(); ++i)
    ASSERT_NEAR(a.pixels[i], 0.5 * (entry->half[0].pixels[i] + entry->half[1].pixels[i]),
                1e-5 * (1 + a.pixels[i]));
  // An entry serves a request that any of its stop rules meets: an error target it reached, a
  // time it rendered at least.
  ReferenceOptions by_error = o;
  by_error.samples = 1000;
  by_error.rel_error = float(j["rel_error"].get<double>() * 1.01);
  EXPECT_TRUE(cache.has(scene, f0, PathClass::direct, 16, 12, by_error));
  by_error.rel_error = float(j["rel_error"].get<double>() * 0.5);
  EXPECT_FALSE(cache.has(scene, f0, PathClass::direct, 16, 12, by_error));
  // A truncated reference is another entry.
  ReferenceOptions truncated = o;
  truncated.max_bounces = 4;
  EXPECT_NE(k, cache.key(scene, f0, PathClass::direct, 16, 12, truncated));
  // More samples than stored: not a hit.
  ReferenceOptions more = o;
  more.samples = 8;
  EXPECT_FALSE(cache.has(scene, f0, PathClass::direct, 16, 12, more));

  int lines = 0;
  ReferenceJobReport first =
      render_references(scene, 0, 1, class_bit(PathClass::direct) | class_bit(PathClass::combined),
                        16, 12, o, cache, [&](const std::string&) { ++lines; });
  EXPECT_EQ(first.cached, 1);
  EXPECT_EQ(first.rendered, 3);
  ReferenceJobReport again =
      render_references(scene, 0, 1, class_bit(PathClass::direct) | class_bit(PathClass::combined),
                        16, 12, o, cache, {});
  EXPECT_EQ(again.rendered, 0);
  EXPECT_EQ(again.cached, 4);
  int files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    std::string ext = e.path().extension().string();
    EXPECT_TRUE(ext == ".exr" || ext == ".json") << e.path();  // no temporary leftovers
    ++files;
  }
  EXPECT_EQ(files, 20);  // 4 entries: mean, variance, two halves, sidecar
  EXPECT_GT(lines, 0);
  std::filesystem::remove_all(dir);
}

}  // namespace reference_test
}  // namespace pb::trace
