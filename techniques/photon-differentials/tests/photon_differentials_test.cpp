// photon-differentials (seed 003): the tracer's photon differentials against closed forms (a point
// light's footprint on a plane, a mirror's transfer, the diffuse re-emission that keeps the area,
// Russian roulette's 1/p), the footprint post-processing and kernel (footprint.h), the toolkit's
// radix sort against std::stable_sort, and through `photonbench run` (with Vulkan validation) the
// GPU's BVH and query checked by the verify hook, a uniformly lit plane's irradiance against its
// closed form, and bad parameters refused at their key.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "../differential_rules.h"
#include "../footprint.h"
#include "photonbench/gpu.h"
#include "photonbench/photons.h"
#include "photonbench/toolkit/radix_sort.h"
#include "photonbench/toolkit/technique.h"
#include "run_fixture.h"
#include "scene/scene.h"
#include "trace/embree_scene.h"
#include "trace/photon_tracer.h"

namespace photon_differentials_test {

using namespace pb::testing;
namespace fs = std::filesystem;

constexpr double kPi = 3.14159265358979;

// A scene file from its text, in this test's scratch folder, loaded and traced.
struct TracedScene {
  TracedScene(const std::string& name, const std::string& text) {
    dir = work_dir("pd", name);
    std::ofstream(dir / "scene.yaml") << text;
    scene = pb::scene::load_scene((dir / "scene.yaml").string());
    state = scene.at(0);
    world = std::make_unique<pb::trace::EmbreeScene>(scene, state);
    tracer = std::make_unique<pb::trace::EmbreePhotonTracer>(*world);
  }
  pb::trace::PhotonBatch trace(pb::trace::TraceSettings s) {
    s.policy = &rules;
    pb::trace::PhotonBatch batch;
    tracer->trace(s, batch);
    return batch;
  }
  pd::DifferentialRules rules;
  fs::path dir;
  pb::scene::Scene scene;
  pb::scene::FrameState state;
  std::unique_ptr<pb::trace::EmbreeScene> world;
  std::unique_ptr<pb::trace::EmbreePhotonTracer> tracer;
};

float delta_of(const pb::trace::PhotonRecord& p) { return std::bit_cast<float>(p.flags); }
double area_of(const pb::trace::PhotonRecord& p) {
  return glm::length(glm::cross(p.footprint_u, p.footprint_v));
}

const char* kPlane = R"(purpose: photon differentials (photon_differentials_test.cpp)
camera: {position: [0, 3, 0], target: [0, 0, 0], up: [0, 0, -1], fov_deg: 60}
lights:
  - {name: bulb, type: point, position: [0, 1, 0], intensity: 1.0}
materials:
  grey: {type: diffuse, albedo: [0.5, 0.5, 0.5]}
objects:
  - {name: floor, shape: {type: quad, size: [40, 40]}, material: grey}
)";

// Eqs. 2-9 and Igehy's transfer: a point light at height 1 over a plane. Every photon's spacing is
// Delta = 2 sqrt(pi / n) (Eq. 9); each semi-axis is Delta d (e - w (e . n) / (w . n)), e one of
// Eq. 8's unit vectors of the photon's direction w (theta from the world's z axis), d the distance
// from the light: Eq. 8's vector carried d along the ray and projected along it onto the plane; the
// footprint's parallelogram is Delta^2 d^2 / cos(theta) (the solid angle per photon on the plane).
TEST(PhotonDifferentials, PointLightFootprintOnAPlaneIsTheClosedForm) {
  TracedScene t("plane", kPlane);
  pb::trace::TraceSettings s;
  s.paths = 20000;
  s.max_bounces = 1;
  s.store = pb::trace::kDirectPhotons;
  auto batch = t.trace(s);
  ASSERT_GT(batch.photons.size(), 9000u);  // the lower half of the sphere, most of it on 40 x 40
  const double delta = 2 * std::sqrt(kPi / s.paths);
  for (const auto& p : batch.photons) {
    const glm::vec3 to = p.position - glm::vec3(0, 1, 0);
    const double d = glm::length(to), cos_theta = std::abs(to.y) / d;
    ASSERT_NEAR(delta_of(p) / delta, 1, 1e-5);
    const glm::dvec3 w = glm::normalize(glm::dvec3(to)), n(0, 1, 0);
    const double sin_theta = std::sqrt(w.x * w.x + w.y * w.y);
    const double cos_phi = w.x / sin_theta, sin_phi = w.y / sin_theta;
    const glm::dvec3 e_theta(-cos_phi * w.z, -sin_phi * w.z, sin_theta),
        e_phi(-sin_phi, cos_phi, 0);
    for (const auto& [axis, e] :
         {std::pair{p.footprint_u, e_theta}, std::pair{p.footprint_v, e_phi}}) {
      const glm::dvec3 want = delta * d * (e - w * (glm::dot(e, n) / glm::dot(w, n)));
      ASSERT_LT(glm::length(glm::dvec3(axis) - want), 2e-3 * glm::length(want))
          << "at " << p.position.x;
    }
    ASSERT_NEAR(area_of(p) / (delta * delta * d * d / cos_theta), 1, 2e-3);
    ASSERT_NEAR(p.footprint_u.y, 0, 1e-5);
    ASSERT_NEAR(p.footprint_v.y, 0, 1e-5);
  }
}

// Specular transfer: a point light 0.5 m over a mirror, photons stored on a diffuse ceiling 1 m
// above the mirror. The footprint is the mirrored light's: Delta^2 D^2 / cos(theta) in area, D the
// distance from the light's image 0.5 m below the mirror.
TEST(PhotonDifferentials, MirrorTransfersTheFootprintOfTheMirroredLight) {
  TracedScene t("mirror", R"(purpose: photon differentials (photon_differentials_test.cpp)
camera: {position: [0, 0.5, 3], target: [0, 0.5, 0], fov_deg: 60}
lights:
  - {name: bulb, type: point, position: [0, 0.5, 0], intensity: 1.0}
materials:
  mirror: {type: mirror, specular: 1.0}
  grey: {type: diffuse, albedo: [0.5, 0.5, 0.5]}
objects:
  - {name: mirror, shape: {type: quad, size: [40, 40]}, material: mirror}
  - {name: ceiling, shape: {type: quad, size: [40, 40]}, material: grey,
     transform: {translate: [0, 1, 0], rotate_deg: [180, 0, 0]}}
)");
  pb::trace::TraceSettings s;
  s.paths = 20000;
  s.max_bounces = 2;
  s.rr_start = 31;
  s.store = pb::trace::kCausticPhotons;
  auto batch = t.trace(s);
  ASSERT_GT(batch.photons.size(), 5000u);
  const double delta = 2 * std::sqrt(kPi / s.paths);
  for (const auto& p : batch.photons) {
    ASSERT_EQ(p.bounce, 1u);
    const glm::vec3 to = p.position - glm::vec3(0, -0.5, 0);
    const double d = glm::length(to), cos_theta = std::abs(to.y) / d;
    ASSERT_NEAR(area_of(p) / (delta * delta * d * d / cos_theta), 1, 2e-3);
    ASSERT_NEAR(glm::dot(p.footprint_u, p.normal), 0, 1e-5);
  }
}

// Area lights (seed 003 defines footprints for point lights only and leaves area lights open, §8):
// a quad light's photon leaves a point of its surface in a cosine-distributed direction, which is
// §4.3's diffuse re-emission at the light. Its footprint starts with the light's area per photon
// A / n and grows along the ray as a point light's does, with Delta = 2 sqrt(pi / n) (Eq. 9): on a
// floor 1 m below, |a1 x a2| = (sqrt(A / n) + Delta t)^2 / cos(theta), t the distance from the
// light (a 2 mm square: t is the distance from its centre to 0.2%), theta the angle at the floor.
TEST(PhotonDifferentials, AreaLightFootprintsGrowWithDistance) {
  struct AreaLight {
    const char* name;
    const char* yaml;
    double area;
  };
  const AreaLight lights[] = {
      {"quad",
       "{name: panel, type: quad, position: [-0.001, 1, -0.001], edge_u: [0.002, 0, 0], "
       "edge_v: [0, 0, 0.002], power: 1}",
       0.002 * 0.002},
      {"disc",
       "{name: torch, type: disc, position: [0, 1, 0], normal: [0, -1, 0], radius: 0.001, "
       "power: 1}",
       kPi * 0.001 * 0.001}};
  for (const AreaLight& light : lights) {
    SCOPED_TRACE(light.name);
    TracedScene t(std::string("area-light-") + light.name,
                  std::string(R"(purpose: photon differentials (photon_differentials_test.cpp)
camera: {position: [0, 3, 0], target: [0, 0, 0], up: [0, 0, -1], fov_deg: 60}
lights:
  - )") + light.yaml + R"(
materials:
  grey: {type: diffuse, albedo: [0.5, 0.5, 0.5]}
objects:
  - {name: floor, shape: {type: quad, size: [40, 40]}, material: grey}
)");
    pb::trace::TraceSettings s;
    s.paths = 20000;
    s.max_bounces = 1;
    s.store = pb::trace::kDirectPhotons;
    auto batch = t.trace(s);
    ASSERT_GT(batch.photons.size(), 15000u);
    const double delta = 2 * std::sqrt(kPi / s.paths);
    size_t far = 0;
    for (const auto& p : batch.photons) {
      const glm::dvec3 to = glm::dvec3(p.position) - glm::dvec3(0, 1, 0);
      const double t_len = glm::length(to), cos_b = std::abs(to.y) / t_len;
      ASSERT_NEAR(delta_of(p) / delta, 1, 1e-5);
      const double expected = std::pow(std::sqrt(light.area / s.paths) + delta * t_len, 2) / cos_b;
      ASSERT_NEAR(area_of(p) / expected, 1, 1e-2) << "at " << p.position.x << ", " << p.position.z;
      far += t_len > 2;
    }
    EXPECT_GT(far, 1000u);  // the growth is seen over a range of distances
  }
}

// A point light between two grey planes 1 m apart (albedo 0.5).
const char* kTwoPlanes = R"(purpose: photon differentials (photon_differentials_test.cpp)
camera: {position: [0, 0.5, 3], target: [0, 0.5, 0], fov_deg: 60}
lights:
  - {name: bulb, type: point, position: [0, 0.5, 0], intensity: 1.0}
materials:
  grey: {type: diffuse, albedo: [0.5, 0.5, 0.5]}
objects:
  - {name: floor, shape: {type: quad, size: [40, 40]}, material: grey}
  - {name: ceiling, shape: {type: quad, size: [40, 40]}, material: grey,
     transform: {translate: [0, 1, 0], rotate_deg: [180, 0, 0]}}
)";

// Eqs. 10-13 and §4.2: a diffuse bounce re-emits from a virtual origin v behind the hit such that
// the footprint there keeps its area A, so at the next hit, t further, the footprint is
// (sqrt(A) + Delta t)^2 / cos(theta) (Delta kept); with Russian roulette at the bounce (survival p
// = the albedo 0.5 here), 1/p of that.
TEST(PhotonDifferentials, DiffuseReemissionKeepsTheFootprintArea) {
  TracedScene t("reemission", kTwoPlanes);
  for (uint32_t rr_start : {31u, 0u}) {
    SCOPED_TRACE(rr_start);
    pb::trace::TraceSettings s;
    s.paths = 4000;
    s.max_bounces = 2;
    s.rr_start = rr_start;
    s.store = pb::trace::kDirectPhotons | pb::trace::kIndirectPhotons;
    auto batch = t.trace(s);
    const double survival = rr_start == 0 ? 0.5 : 1.0;
    size_t pairs = 0;
    for (size_t i = 0; i + 1 < batch.photons.size(); ++i) {
      const auto &a = batch.photons[i], &b = batch.photons[i + 1];
      if (a.path != b.path || a.bounce != 0 || b.bounce != 1) continue;
      const double delta = delta_of(a), t_len = glm::length(b.position - a.position);
      const double cos_b = std::abs(glm::dot(glm::normalize(b.position - a.position), b.normal));
      const double expected = std::pow(std::sqrt(area_of(a)) + delta * t_len, 2) / cos_b / survival;
      ASSERT_NEAR(area_of(b) / expected, 1, 3e-3) << "path " << a.path;
      ASSERT_EQ(delta_of(b), delta_of(a));
      ++pairs;
    }
    EXPECT_GT(pairs, rr_start == 0 ? 1000u : 3000u);
  }
}

// §4.2 with first_hit_roulette: the technique's trace settings (differential_trace_settings) play
// Russian roulette "whenever a photon encounters a surface", the first hit included: between two
// planes of albedo 0.5 half the paths leave their first hit, each with its footprint grown by
// 1 / p = 2 there. Without it (the default) every path leaves its first hit, its footprint kept.
TEST(PhotonDifferentials, FirstHitRouletteGrowsTheFootprintAtTheFirstHit) {
  TracedScene t("first-hit-roulette", kTwoPlanes);
  for (bool first_hit_roulette : {true, false}) {
    SCOPED_TRACE(first_hit_roulette);
    pb::trace::TraceSettings s;
    s.paths = 4000;
    s.max_bounces = 2;
    s.store = pb::trace::kIndirectPhotons;
    const pb::trace::TraceSettings settings =
        pd::differential_trace_settings(s, t.rules, first_hit_roulette);
    EXPECT_EQ(settings.policy, &t.rules);
    EXPECT_TRUE(settings.store & pb::trace::kDirectPhotons);  // the lit area for T_auto
    auto batch = t.trace(settings);
    const double survival = first_hit_roulette ? 0.5 : 1.0;
    size_t first = 0, second = 0, pairs = 0;
    for (size_t i = 0; i < batch.photons.size(); ++i) {
      const auto& a = batch.photons[i];
      first += a.bounce == 0, second += a.bounce == 1;
      if (i + 1 == batch.photons.size() || a.bounce != 0) continue;
      const auto& b = batch.photons[i + 1];
      if (b.path != a.path || b.bounce != 1) continue;
      const double t_len = glm::length(b.position - a.position);
      const double cos_b = std::abs(glm::dot(glm::normalize(b.position - a.position), b.normal));
      const double expected = std::pow(std::sqrt(area_of(a)) + delta_of(a) * t_len, 2) / cos_b;
      ASSERT_NEAR(area_of(b) / expected, 1 / survival, 6e-3) << "path " << a.path;
      ++pairs;
    }
    ASSERT_GT(first, 3000u);
    EXPECT_NEAR(double(second) / first, survival, 0.05);
    EXPECT_GT(pairs, 1000u);
  }
}

pb::trace::PhotonRecord photon(glm::vec3 u, glm::vec3 v, uint32_t bounce, uint32_t mask,
                               float delta) {
  pb::trace::PhotonRecord p{};
  p.position = glm::vec3(0.f);
  p.normal = glm::vec3(0, 1, 0);
  p.direction = glm::normalize(glm::vec3(0.3f, -1, 0.1f));
  p.power = glm::vec3(2.f, 1.f, 0.5f);
  p.footprint_u = u, p.footprint_v = v;
  p.bounce = bounce, p.specular_mask = mask;
  p.flags = std::bit_cast<uint32_t>(delta);
  return p;
}

// §4.3 and §7 by hand: a diffusely reflected photon's semi-axes are times (|a| / Delta)^e, then s;
// a specular-only one's (L S D) only s_specular; then each is clamped to r_max; Table 3's bins.
TEST(PhotonDifferentials, PostProcessingFollowsTheRules) {
  pd::PostProcess pp;
  pp.smoothing = 10, pp.smoothing_specular = 5, pp.exponent = -0.75f, pp.r_max = 0.7f;
  const float delta = 0.01f;
  glm::vec3 a1, a2;
  auto diffuse = photon({0.02f, 0, 0}, {0, 0, 0.005f}, 1, 0u, delta);  // L D D
  pd::scaled_semiaxes(diffuse, pp, a1, a2);
  EXPECT_NEAR(glm::length(a1), 10 * 0.02 * std::pow(2.0, -0.75), 1e-6);
  EXPECT_NEAR(glm::length(a2), 10 * 0.005 * std::pow(0.5, -0.75), 1e-6);
  pp.compress_semiaxis = true;
  pd::scaled_semiaxes(diffuse, pp, a1, a2);
  EXPECT_NEAR(glm::length(a1), 10 * 0.02 * std::pow(0.02, -0.75), 1e-5);
  pp.compress_semiaxis = false;
  auto caustic = photon({0.02f, 0, 0}, {0, 0, 0.005f}, 1, 1u, delta);  // L S D
  pd::scaled_semiaxes(caustic, pp, a1, a2);
  EXPECT_NEAR(glm::length(a1), 5 * 0.02, 1e-7);
  EXPECT_NEAR(glm::length(a2), 5 * 0.005, 1e-7);
  auto caustic_indirect = photon({0.02f, 0, 0}, {0, 0, 0.005f}, 2, 1u, delta);  // L S D D
  pd::scaled_semiaxes(caustic_indirect, pp, a1, a2);
  EXPECT_NEAR(glm::length(a1), 10 * 0.02 * std::pow(2.0, -0.75), 1e-6);
  glm::vec3 long_axis(2.f, 0, 0);
  EXPECT_TRUE(pd::clamp_semiaxis(long_axis, 0.7f));
  EXPECT_NEAR(glm::length(long_axis), 0.7, 1e-6);
  EXPECT_EQ(pd::radius_bin(0.049f), 0u);
  EXPECT_EQ(pd::radius_bin(0.051f), 1u);
  EXPECT_EQ(pd::radius_bin(0.99f), 19u);
  EXPECT_EQ(pd::radius_bin(3.f), 20u);
  EXPECT_EQ(pd::t_auto(10, 4, 2), 5u);
  EXPECT_EQ(pd::t_auto(0, 4, 2), 1u);
}

// The footprint's thickness along its surface's normal (README "Footprint thickness"): by default
// h = 0.5 sqrt(|a1| |a2|), the sweep's choice, so that a round footprint on a floor reaches a wall
// point beside it only within half its radius of the floor (a ball, normal_extent 1, counts its
// flux density on the wall up to a full radius: +7.1% in cornell-box's corner band).
TEST(PhotonDifferentials, DefaultFootprintIsHalfAsThickAsItIsWide) {
  pd::PostProcess pp;
  pp.smoothing = 1, pp.exponent = 0, pp.r_max = 10;
  const float r = 0.1f;
  auto p = photon({r, 0, 0}, {0, 0, r}, 1, 0u, 1.f);  // round, on the floor (normal +y)
  pd::PdFootprint f;
  pd::BvhBox box;
  ASSERT_TRUE(pd::make_footprint(p, 0, pp, f, box));
  // A wall through the photon's position facing -x (the photon arrives from +x above it).
  const glm::vec3 wall_normal(-1, 0, 0);
  ASSERT_GT(pd::contribution(f, {0, 0.45f * r, 0}, wall_normal, false, true).x, 0);
  EXPECT_EQ(pd::contribution(f, {0, 0.55f * r, 0}, wall_normal, false, true).x, 0);
  EXPECT_NEAR(box.hi.y - p.position.y, 0.5f * r, 1e-6);
}

// Eq. 1's kernel normalised by pi |a1 x a2|: a skewed footprint (non-orthogonal semi-axes) in
// its own plane integrates to the photon's flux, with either kernel; the ellipsoid's box holds it.
TEST(PhotonDifferentials, FootprintKernelIntegratesToTheFlux) {
  auto p = photon({0.3f, 0, 0.05f}, {0.12f, 0, 0.2f}, 1, 0u, 1.f);
  pd::PostProcess pp;
  pp.smoothing = 1, pp.exponent = 0, pp.r_max = 10;
  pd::PdFootprint f;
  pd::BvhBox box;
  ASSERT_TRUE(pd::make_footprint(p, 0, pp, f, box));
  EXPECT_NEAR(f.area, kPi * glm::length(glm::cross(p.footprint_u, p.footprint_v)), 1e-6);
  for (bool epanechnikov : {false, true}) {
    const int n = 1200;
    const double h = 1.0 / n;
    glm::dvec3 sum(0.0);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        glm::vec3 x(float(-0.5 + (i + 0.5) * h), 0.f, float(-0.5 + (j + 0.5) * h));
        glm::vec3 c = pd::contribution(f, x, {0, 1, 0}, epanechnikov, true);
        if (c.x > 0) {
          EXPECT_TRUE(glm::all(glm::lessThanEqual(box.lo, x)) &&
                      glm::all(glm::greaterThanEqual(box.hi, x)));
        }
        sum += glm::dvec3(c) * h * h;
      }
    SCOPED_TRACE(epanechnikov);
    EXPECT_NEAR(sum.x / p.power.x, 1, 5e-3);
    EXPECT_NEAR(sum.z / p.power.z, 1, 5e-3);
  }
  // Arriving from below the query's surface: nothing with the normal gate.
  EXPECT_EQ(pd::contribution(f, glm::vec3(0.f), {0, -1, 0}, false, true).x, 0);
}

pb::gpu::Device& device() {
  static pb::gpu::Device d({"", validation_on()});
  return d;
}

// The toolkit's radix sort against std::stable_sort on random keys with many repeats (so
// stability shows), at sizes around its 256-key blocks, for 30-bit keys (8 passes: seed 003's
// Morton codes) and 9-bit ones (3 passes, an odd count: the copy back).
TEST(PhotonDifferentialsRadixSort, EqualsStdStableSortOnRandomKeys) {
  auto& gpu = device();
  pb::toolkit::RadixSort sort;
  sort.setup(gpu, "test/radix");
  std::mt19937 rng(7);
  for (uint32_t bits : {30u, 9u})
    for (uint32_t n : {1u, 2u, 255u, 256u, 257u, 4097u, 100000u}) {
      SCOPED_TRACE(testing::Message() << n << " keys of " << bits << " bits");
      std::uniform_int_distribution<uint32_t> key(0, (1u << bits) - 1u);
      std::uniform_int_distribution<uint32_t> few(0, 40);
      std::vector<uint32_t> keys(n), values(n);
      for (uint32_t i = 0; i < n; ++i) {
        keys[i] = i % 3 == 0 ? key(rng) : (few(rng) << (bits - 6));
        values[i] = i;
      }
      auto kb = pb::toolkit::storage_buffer(gpu, "test/keys", n * 4ull);
      auto vb = pb::toolkit::storage_buffer(gpu, "test/values", n * 4ull);
      gpu.upload(kb, keys.data(), n * 4ull);
      gpu.upload(vb, values.data(), n * 4ull);
      sort.reserve(n);
      gpu.submit_and_wait([&](vk::CommandBuffer cmd) {
        sort.record(cmd, kb, vb, n, bits);
        pb::gpu::full_barrier(cmd);
      });
      std::vector<uint32_t> order(n);
      std::iota(order.begin(), order.end(), 0u);
      std::stable_sort(order.begin(), order.end(),
                       [&](uint32_t a, uint32_t b) { return keys[a] < keys[b]; });
      std::vector<uint32_t> got_keys(n), got_values(n), want_keys(n);
      gpu.download(kb, got_keys.data(), n * 4ull);
      gpu.download(vb, got_values.data(), n * 4ull);
      for (uint32_t i = 0; i < n; ++i) want_keys[i] = keys[order[i]];
      EXPECT_EQ(got_keys, want_keys);
      EXPECT_EQ(got_values, order);  // the values say where each key came from: stable
    }
}

// The runs below share one scratch folder per test.
std::string header(const std::string& scenes, const std::string& size = "[96, 64]") {
  return "name: pd-test\nresolution: " + size + "\nseed: 1\nscenes: [" + scenes +
         "]\nframes: {warmup: 0, count: 2, metrics_every: 0}\nlimits: {cell_seconds: 300}\n";
}

// The GPU's BVH and query on cornell-box (diffuse, with the default compression) and
// cornell-glass with caustics (s = 5 photons too), at T_auto and two fixed thresholds: the verify
// hook finds every footprint in exactly one leaf reached from the root, every node's box holding
// its children's and every leaf's its footprints', and each sampled query equal to the sum over
// every footprint; every GPU footprint record equal to footprint.h's make_footprint of the same
// photon, and the GPU's area sum, T_auto and Table 3 histogram equal to the CPU's counts (the
// histogram holds two semi-axes per hit).
TEST(PhotonDifferentialsRun, BvhAndQueryMatchTheBruteForceCheck) {
  fs::path dir = work_dir("pd", "verify");
  std::string yaml = header("cornell-box, cornell-glass") +
                     "techniques:\n"
                     "  - {technique: photon-differentials, params: {photons: 6000, verify: true, "
                     "caustics: true, leaf_threshold: [0, 1, 16]}}\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << "see " << (dir / "log.txt");
  auto cells = cells_with_prefix(dir, "cornell");
  ASSERT_EQ(cells.size(), 6u);
  for (const fs::path& cell : cells) {
    SCOPED_TRACE(cell.filename().string());
    auto sums = counters(cell);
    EXPECT_GT(sums["hits"], 1000);
    EXPECT_GT(sums["morton_runs"], 100);
    EXPECT_GT(sums["bvh_nodes"], 1);
    EXPECT_EQ(sums["bvh_violations"], 0) << warnings(cell);
    EXPECT_GT(sums["query_checked"], 100);
    EXPECT_EQ(sums["query_mismatches"], 0) << warnings(cell);
    EXPECT_EQ(sums["footprints_off"], 0) << warnings(cell);
    EXPECT_EQ(sums["totals_off"], 0) << warnings(cell);
    EXPECT_EQ(sums["truncated_queries"], 0);
    EXPECT_GT(sums["hits_contributing"], 0);
    double histogram = 0;
    for (const auto& [name, value] : sums)
      if (name.rfind("radius_", 0) == 0) histogram += value;
    EXPECT_EQ(histogram, 2 * sums["hits"]);
  }
}

// Eq. 1 on the closed-form case: the point light at height 1 over the plane, photons stored at the
// first hit (store_first_hit: direct light, E = I h / (h^2 + rho^2)^(3/2)); each 32 x 32-pixel
// block's mean of the estimate against E's mean over the block's pixels, within 4 Poisson standard
// deviations of the block's photons (1 / sqrt(n)) plus 1.5% (the kernel's smoothing of E's
// curvature: footprints of 0.03 to 0.1 m against E's scale of 1 m), for both kernels.
TEST(PhotonDifferentialsRun, UniformlyLitPlaneMatchesTheClosedForm) {
  fs::path dir = work_dir("pd", "plane");
  std::ofstream(dir / "plane.yaml") << kPlane;
  const double paths = 200000;
  std::string yaml =
      "name: pd-plane\nresolution: [128, 128]\nseed: 1\nscenes: [" + (dir / "plane.yaml").string() +
      "]\nframes: {warmup: 0, count: 1, metrics_every: 1}\nmetrics: [psnr]\n"
      "limits: {cell_seconds: 300}\nreference: {samples: 2, cache_dir: " +
      (dir / "refs").string() +
      "}\ntechniques:\n  - {technique: photon-differentials, params: {photons: 200000, "
      "store_first_hit: true, smoothing_specular: 4, kernel: [uniform, epanechnikov]}}\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << "see " << (dir / "log.txt");
  const double half = std::tan(30 * kPi / 180) * 3, photon_power = 4 * kPi / paths;
  for (const char* kernel : {"uniform", "epanechnikov"}) {
    SCOPED_TRACE(kernel);
    fs::path cell = find_cell(dir, "photon-differentials", {{"kernel", kernel}});
    ASSERT_FALSE(cell.empty());
    auto image = frame_image(cell, 0, "indirect");
    ASSERT_EQ(image.width, 128);
    for (int by = 0; by < 4; ++by)
      for (int bx = 0; bx < 4; ++bx) {
        double got = 0, want = 0;
        for (int j = by * 32; j < by * 32 + 32; ++j)
          for (int i = bx * 32; i < bx * 32 + 32; ++i) {
            double x = ((i + 0.5) / 128 * 2 - 1) * half, z = ((j + 0.5) / 128 * 2 - 1) * half;
            want += 1.0 / std::pow(1 + x * x + z * z, 1.5);
            got += image.at(i, j, 0) / (0.5 / kPi);
          }
        got /= 1024, want /= 1024;
        const double block_area = std::pow(2 * half / 4, 2);
        const double photons = want * block_area / photon_power;
        const double tolerance = 4 / std::sqrt(photons) + 0.015;
        EXPECT_NEAR(got / want, 1, tolerance) << "block " << bx << "," << by;
      }
  }
}

// The descriptor's check refuses parameters that do not go together, at the key's file:line.
TEST(PhotonDifferentialsRun, BadParametersAreRefusedAtTheirKey) {
  fs::path dir = work_dir("pd", "bad");
  std::string yaml = header("cornell-box") +
                     "techniques:\n"
                     "  - technique: photon-differentials\n"
                     "    params: {leaf_threshold: 8, t_auto_constant: 3}\n";
  std::ofstream(dir / "config.yaml") << yaml;
  std::string cmd = std::string(PB_BINARY_DIR "/photonbench validate ") +
                    (dir / "config.yaml").string() + " > " + (dir / "log.txt").string() + " 2>&1";
  int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 2);
  std::ifstream in(dir / "log.txt");
  std::string log((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(log.find("config.yaml:9:"), std::string::npos) << log;
  EXPECT_NE(log.find("t_auto_constant"), std::string::npos) << log;
  // A value outside its range is the harness's schema check, also at its key.
  std::ofstream(dir / "config.yaml") << header("cornell-box") +
                                            "techniques:\n"
                                            "  - technique: photon-differentials\n"
                                            "    params: {compression_exponent: 5}\n";
  status = std::system(cmd.c_str());
  EXPECT_EQ(WEXITSTATUS(status), 2);
  std::ifstream again(dir / "log.txt");
  log.assign((std::istreambuf_iterator<char>(again)), std::istreambuf_iterator<char>());
  EXPECT_NE(log.find("compression_exponent"), std::string::npos) << log;
}

}  // namespace photon_differentials_test
