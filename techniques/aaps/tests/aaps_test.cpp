// aaps: the task buffer's quadtree walk against the tracer's emission order, the density update,
// the tracer's AAPS rules and energy on cornell-glass, and end to end through `photonbench run`
// (with Vulkan validation) the screen-summed caustics against the caustics reference per msaa mode
// and the adaptivity of the density texture; indirect: splat_bvh's ellipse test and a caustic seen
// in a mirror against its closed form.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <numeric>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "../footprint.h"
#include "../photon_rules.h"
#include "../splat_bvh.h"
#include "../task_buffer.h"
#include "io/image.h"
#include "photonbench/error.h"
#include "photonbench/photons.h"
#include "reference/reference.h"
#include "run_fixture.h"
#include "scene/scene.h"
#include "trace/embree_scene.h"
#include "trace/photon_tracer.h"

namespace fs = std::filesystem;

namespace aaps_test {

// AAPS's tracer policies for a test: the task buffer of each light and the caustic rule.
struct AapsPhotons {
  explicit AapsPhotons(std::vector<const pb::trace::EmissionDensity*> counts) {
    emission.set_counts(std::move(counts));
  }
  pb::trace::TraceSettings settings() {
    pb::trace::TraceSettings s;
    s.seed_per_frame = false;
    s.emission = &emission;
    s.policy = &rule;
    return s;
  }
  aaps::GridEmission emission;
  aaps::CausticSplitRule rule;
};

using namespace pb::testing;

// Densities with every case the leaf rule meets: 0 and below 1 (no photons), non-squares (floored
// to a square), exact squares, large values.
std::vector<float> mixed_density(uint32_t side, uint32_t seed) {
  std::mt19937 rng(seed);
  const float values[] = {0.f, 0.5f, 1.f, 3.9f, 4.f, 8.f, 9.f, 17.5f, 100.f};
  std::vector<float> d(size_t(side) * side);
  for (float& v : d) v = values[rng() % 9];
  return d;
}

// §1.4: the thesis's traversal (each task id walks the sum quadtree to its leaf, then its grid
// cell) visits exactly the (texel, cell) pairs the tracer emits, task by task.
TEST(AapsTaskBuffer, QuadtreeWalkIsTheTracersEmissionOrder) {
  for (uint32_t side : {1u, 2u, 16u}) {
    SCOPED_TRACE(side);
    pb::trace::EmissionDensity counts;
    counts.width = counts.height = int(side);
    counts.texels = mixed_density(side, side);
    aaps::SumQuadtree tree;
    tree.build(counts.texels, side);
    aaps::TaskGrid grid(counts);
    uint32_t expected_total = 0;
    for (float d : counts.texels) expected_total += aaps::grid_side(d) * aaps::grid_side(d);
    ASSERT_EQ(tree.root(), expected_total);
    ASSERT_EQ(grid.tasks(), expected_total);
    std::set<std::pair<uint32_t, uint32_t>> seen;
    uint32_t off_centre = 0;
    for (uint32_t t = 0; t < grid.tasks(); ++t) {
      aaps::SumQuadtree::Leaf leaf = tree.walk(t);
      aaps::TaskGrid::Task task = grid.locate(t);
      ASSERT_EQ(leaf.texel, task.texel) << "task " << t;
      ASSERT_EQ(leaf.cell, task.cell) << "task " << t;
      ASSERT_EQ(leaf.m, task.m);
      ASSERT_EQ(leaf.m, aaps::grid_side(counts.texels[leaf.texel]));
      ASSERT_LT(leaf.cell, leaf.m * leaf.m);
      seen.insert({leaf.texel, leaf.cell});
      // The cell centre lies inside its texel.
      uint32_t x = task.texel % side, y = task.texel / side;
      EXPECT_GE(task.uv.x * side, float(x));
      EXPECT_LT(task.uv.x * side, float(x + 1));
      EXPECT_GE(task.uv.y * side, float(y));
      EXPECT_LT(task.uv.y * side, float(y + 1));
      // emission_jitter: a point of the same grid cell, not its centre.
      glm::vec2 j = grid.jittered(task), cell = glm::vec2(task.uv) * float(side * task.m);
      glm::vec2 jc = j * float(side * task.m);
      EXPECT_EQ(std::floor(jc.x), std::floor(cell.x)) << "task " << t;
      EXPECT_EQ(std::floor(jc.y), std::floor(cell.y)) << "task " << t;
      off_centre += j != task.uv ? 1 : 0;
    }
    EXPECT_GT(off_centre, expected_total / 2);
    EXPECT_EQ(seen.size(), expected_total);  // every (texel, cell) once
  }
}

// §1.10 b-c on a 2x2 texture, by hand: D' = D A / A_t + v g, then w_t D' + (1 - w_t) times the
// weighted mean of the texel's and its two in-range neighbours' previous values, floored.
TEST(AapsTaskBuffer, DensityUpdateFollowsTheFormula) {
  aaps::FeedbackParams p;
  p.target_area = 10, p.variance_gain = 4, p.temporal_weight = 0.25f, p.neighbour_weight = 0.5f;
  p.density_min = 4, p.density_max = 0;
  std::vector<float> d = {8, 16, 4, 4}, area = {20, 5, 0, 0}, var = {0, 0.5f, 0, 0};
  aaps::update_density(d, area, var, 2, p);
  // texel 0: D' = 8 * 2 = 16; neighbours 16 (right), 4 (below): mean (8 + 8 + 2) / 2 = 9.
  EXPECT_NEAR(d[0], 0.25f * 16 + 0.75f * 9, 1e-5);
  // texel 1: D' = 16 * 0.5 + 2 = 10; neighbours 8, 4: (16 + 4 + 2) / 2 = 11.
  EXPECT_NEAR(d[1], 0.25f * 10 + 0.75f * 11, 1e-5);
  // texel 2: D' = 0; neighbours 8, 4: (4 + 4 + 2) / 2 = 5 -> 3.75, floored to 4.
  EXPECT_NEAR(d[2], 4, 1e-5);
  p.density_max = 6;
  std::vector<float> high = {100, 100, 100, 100}, none(4, 0.f);
  aaps::update_density(high, std::vector<float>(4, 10.f), none, 2, p);
  EXPECT_EQ(high[0], 6);
}

// §3.1.2 / §3.3.3: the principal semi-axes of the ellipse whose conjugate semi-diameters are the
// two scaled differentials describe the same ellipse (every point P + cos t a + sin t b lies on
// the principal axes' ellipse), are orthogonal, keep its area pi |a x b| and lie in its plane;
// above max_anisotropy the minor axis grows to major / max_anisotropy along the same direction.
TEST(AapsFootprint, PrincipalAxesDescribeTheSameEllipse) {
  const glm::vec3 cases[][2] = {{{0.3f, 0, 0}, {0.1f, 0.2f, 0}},
                                {{0.02f, 0.05f, -0.01f}, {-0.04f, 0.01f, 0.03f}},
                                {{0, 0, 0.1f}, {0, 0.1f, 0.1f}},
                                {{0.1f, 0, 0}, {0, 0.1f, 0}}};
  for (const auto& c : cases) {
    const glm::vec3 a = c[0], b = c[1];
    glm::vec3 major, minor;
    aaps::principal_axes(a, b, 1e6f, major, minor);
    const float M = glm::length(major), m = glm::length(minor);
    SCOPED_TRACE(testing::Message() << "a " << a.x << "," << a.y << "," << a.z);
    ASSERT_GT(m, 0);
    EXPECT_GE(M, m * (1 - 1e-5f));
    EXPECT_NEAR(glm::dot(major, minor) / (M * m), 0, 1e-5);
    EXPECT_NEAR(M * m / glm::length(glm::cross(a, b)), 1, 1e-4);
    const glm::vec3 n = glm::normalize(glm::cross(a, b));
    EXPECT_NEAR(glm::dot(major, n) / M, 0, 1e-5);
    EXPECT_NEAR(glm::dot(minor, n) / m, 0, 1e-5);
    for (int k = 0; k < 16; ++k) {
      float t = float(k) * 0.3927f;
      glm::vec3 q = std::cos(t) * a + std::sin(t) * b;
      float x = glm::dot(q, major) / (M * M), y = glm::dot(q, minor) / (m * m);
      EXPECT_NEAR(x * x + y * y, 1, 1e-4) << "t " << t;
    }
  }
  // Clamped: a 100:1 ellipse at max_anisotropy 16 keeps its major axis and direction.
  glm::vec3 major, minor;
  aaps::principal_axes({1, 0, 0}, {0, 0.01f, 0}, 16, major, minor);
  EXPECT_NEAR(major.x, 1, 1e-6);
  EXPECT_NEAR(glm::length(minor), 1.f / 16, 1e-6);
  EXPECT_NEAR(std::abs(minor.y), 1.f / 16, 1e-6);
}

// §1.10a: the variance term of the feedback by hand on a 4x2 screen. The previous frame's camera
// is shifted by half the screen's width in NDC (one pixel here is 0.5 NDC), so a photon is looked
// up at its reprojected pixel, not at its current one; no value where it was off screen.
TEST(AapsTaskBuffer, VarianceTermReprojectsAndWeighs) {
  const uint32_t width = 4, height = 2;
  glm::mat4 now_vp(1.f), prev_vp = glm::mat4(1.f);
  prev_vp[3][0] = 0.5f;  // NDC x + 0.5 in the previous frame: one pixel to the right
  // Pixel (x, y) of NDC (-0.75 + 0.5 x, -0.5 + y).
  const std::vector<float> now = {2, 0, 0, 3, 1, 0, 0, 0};
  const std::vector<float> prev = {2, 1, 0, 5, 0, 0, 3, 0};
  std::vector<aaps::VarianceInput> photons = {
      {{-0.75f, -0.5f, 0}, 0, 0.5f},  // now (0,0) = 2, previously (1,0) = 1: 0.5 * 1/2
      {{0.75f, -0.5f, 0}, 0, 0.5f},   // previously off screen (x 1.25): nothing
      {{-0.25f, -0.5f, 0}, 1, 1.0f},  // now (1,0) = 0, previously (2,0) = 0: nothing
      {{-0.75f, 0.5f, 0}, 2, 0.25f},  // now (0,1) = 1, previously (1,1) = 0: 0.25 * 1
      {{0.25f, 0.5f, 0}, 3, 1.0f},    // now (2,1) = 0, previously (3,1) = 0: nothing
      {{0.25f, -0.5f, 0}, 3, 0.5f},   // now (2,0) = 0, previously (3,0) = 5: 0.5 * 1
  };
  std::vector<float> variance(4, 0.f);
  aaps::accumulate_variance(photons, now.data(), now_vp, prev, prev_vp, width, height, variance);
  EXPECT_NEAR(variance[0], 0.25f, 1e-6);
  EXPECT_NEAR(variance[1], 0.f, 1e-6);
  EXPECT_NEAR(variance[2], 0.25f, 1e-6);
  EXPECT_NEAR(variance[3], 0.5f, 1e-6);
  // No previous frame: no term.
  std::vector<float> first(4, 0.f);
  aaps::accumulate_variance(photons, now.data(), now_vp, {}, prev_vp, width, height, first);
  EXPECT_EQ(first, std::vector<float>(4, 0.f));
}

struct CornellGlass {
  pb::scene::Scene scene = pb::scene::load_scene(PB_SOURCE_DIR "/scenes/cornell-glass.yaml");
  pb::scene::FrameState state = scene.at(0);
  pb::trace::EmbreeScene world{scene, state};
};

// §1.5 on cornell-glass with a uniform task buffer: every photon is a caustic photon (L S+ D) whose
// first hit was the sphere, and the grid emits exactly texels * floor(sqrt(D))^2 photons. Energy:
// the light reaching the sphere is Phi * Omega / (4 pi) (Omega its solid angle from the light);
// what is stored is that, less what escapes through the box's open front and the chained paths
// the rules drop (refraction after an internal reflection: about F (1 - F)^2 ~ 4% of it).
TEST(AapsTrace, RulesAndEnergyOnCornellGlass) {
  CornellGlass c;
  pb::trace::EmbreePhotonTracer tracer(c.world);
  ASSERT_EQ(tracer.light_count(), 1u);
  const uint32_t side = 64;
  pb::trace::EmissionDensity density;
  density.width = density.height = int(side);
  density.texels.assign(side * side, 17.f);  // floored to 16: a 4x4 grid per texel
  AapsPhotons aaps_photons({&density});
  pb::trace::TraceSettings s = aaps_photons.settings();
  s.max_bounces = 8;
  pb::trace::PhotonBatch batch;
  pb::trace::TraceStats stats = tracer.trace(s, batch);
  EXPECT_EQ(stats.paths, uint64_t(side) * side * 16);
  ASSERT_GT(batch.photons.size(), 1000u);
  uint32_t sphere = ~0u;
  for (uint32_t o = 0; o < c.scene.objects.size(); ++o)
    if (c.scene.objects[o].name == "sphere") sphere = o;
  const uint32_t sphere_first = c.world.scene_triangle(sphere, 0);
  const uint32_t sphere_end =
      sphere_first + uint32_t(c.scene.objects[sphere].mesh.triangles.size());
  double stored = 0;
  for (const auto& p : batch.photons) {
    ASSERT_EQ(pb::trace::photon_kind(p), pb::trace::kCausticPhotons);
    ASSERT_FALSE(p.triangle >= sphere_first && p.triangle < sphere_end);  // not on the sphere
    ASSERT_LT(p.bounce, s.max_bounces);
    ASSERT_LT(p.path, stats.paths);
    stored += (p.power.x + p.power.y + p.power.z) / 3.0;
  }
  glm::vec3 power = tracer.light_power(0);
  glm::vec3 light = c.state.lights[0].position;
  double d = glm::length(light - glm::vec3(0.5f, 0.2f, 0.5f)), r = 0.2;
  double omega = 2 * M_PI * (1 - std::sqrt(1 - r * r / (d * d)));
  double expected = (power.x + power.y + power.z) / 3.0 * omega / (4 * M_PI);
  double ratio = stored / expected;
  std::printf("stored caustic power / power reaching the sphere = %.4f\n", ratio);
  EXPECT_GT(ratio, 0.89);  // measured 0.9097 (the grid emission is deterministic)
  EXPECT_LT(ratio, 0.93);
}

// A seed axis' cell (the tracer's seed_scramble, cell/world.cpp) emits at other points of the
// same grid cells, so `seeds: K` measures the spread of the jittered emission: the jitter is AAPS's
// only randomness. The first seed (no scramble) emits as before, and each seed every frame alike.
TEST(AapsTrace, ASeedAxisCellJittersWithinTheSameCells) {
  CornellGlass c;
  const uint32_t side = 32;
  pb::trace::EmissionDensity density;
  density.width = density.height = int(side);
  density.texels.assign(side * side, 16.f);  // a 4x4 grid per texel
  AapsPhotons aaps_photons({&density});
  pb::trace::TraceSettings s = aaps_photons.settings();
  auto positions = [&](std::optional<uint32_t> scramble, bool jitter) {
    pb::trace::EmbreePhotonTracer tracer(c.world, scramble);
    aaps_photons.emission.set_jitter(jitter);
    pb::trace::PhotonBatch batch;
    tracer.trace(s, batch);
    std::vector<glm::vec3> out;
    for (const auto& p : batch.photons) out.push_back(p.position);
    return out;
  };
  const auto first = positions(std::nullopt, true), again = positions(std::nullopt, true);
  const auto seed2 = positions(7u, true), seed2_again = positions(7u, true);
  ASSERT_GT(first.size(), 100u);
  EXPECT_EQ(first, again);
  EXPECT_EQ(seed2, seed2_again);
  EXPECT_NE(first, seed2) << "a seed axis' cell emits the first seed's photons";
  // Without the jitter the grid is the cell centres whatever the seed.
  EXPECT_EQ(positions(std::nullopt, false), positions(7u, false));
  // Every scrambled point stays in its task's cell.
  aaps::TaskGrid grid(density);
  uint32_t moved = 0;
  for (uint32_t t = 0; t < grid.tasks(); ++t) {
    const aaps::TaskGrid::Task task = grid.locate(t);
    const glm::vec2 cell = task.uv * float(side * task.m);
    const glm::vec2 j = grid.jittered(task, 7u) * float(side * task.m);
    EXPECT_EQ(std::floor(j.x), std::floor(cell.x)) << "task " << t;
    EXPECT_EQ(std::floor(j.y), std::floor(cell.y)) << "task " << t;
    moved += grid.jittered(task, 7u) != grid.jittered(task) ? 1 : 0;
  }
  EXPECT_GT(moved, grid.tasks() / 2);
}

// §3.1.5's energy fractions on a spot light (torus-in-glass-cube: inner 12, outer 20 degrees). The
// photons leave the cone uniformly, each carrying the uniform cone's power times the falloff in its
// direction, so the texels do not carry equal power: the tracer's texel powers sum to the light's
// falloff-integrated power, those wholly inside the inner cone carry the uniform cone's share
// (1.47x the light's power / texels), and a texel's recorded photons (the cube's first hit: both
// Fresnel parts, less what the rules drop) have energy fractions that sum to at most one.
TEST(AapsTrace, SpotTexelEnergiesFollowTheFalloff) {
  pb::scene::Scene scene = pb::scene::load_scene(PB_SOURCE_DIR "/scenes/torus-in-glass-cube.yaml");
  pb::scene::FrameState state = scene.at(0);
  pb::trace::EmbreeScene world{scene, state};
  pb::trace::EmbreePhotonTracer tracer(world);
  ASSERT_EQ(tracer.light_count(), 1u);
  const uint32_t side = 32;
  pb::trace::EmissionDensity density;
  density.width = density.height = int(side);
  density.texels.assign(side * side, 4.f);
  AapsPhotons aaps_photons({&density});
  pb::trace::PhotonBatch batch;
  tracer.trace(aaps_photons.settings(), batch);
  const std::vector<std::vector<float>> power_per_texel =
      aaps_photons.emission.power_per_texel(batch.emitted_power);
  ASSERT_EQ(power_per_texel.size(), 1u);
  ASSERT_EQ(power_per_texel[0].size(), size_t(side) * side);
  const glm::vec3 power = tracer.light_power(0);
  const double light = (power.x + power.y + power.z) / 3.0;
  const double sum = std::accumulate(power_per_texel[0].begin(), power_per_texel[0].end(), 0.0);
  EXPECT_NEAR(sum / light, 1.0, 0.005);
  // The domain's u is 1 - cos(theta) over 1 - cos(outer): the inner cone is u < 0.362.
  const pb::scene::Light& spot = state.lights[0];
  const double co = std::cos(spot.spot_outer), ci = std::cos(spot.spot_inner);
  const double inner_share = (1 - co) / ((1 - ci) + 0.5 * (ci - co));
  for (uint32_t x = 0; x * (1 - co) < side * (1 - ci) - (1 - co); ++x)
    EXPECT_NEAR(power_per_texel[0][x] / (light / (side * side)), inner_share, 1e-3) << x;
  aaps::TaskGrid grid(density);
  std::vector<double> fractions(size_t(side) * side, 0.0);
  for (const pb::trace::PhotonRecord& p : batch.photons) {
    uint32_t texel = grid.locate(p.path).texel;
    fractions[texel] += aaps::energy_fraction(p.power, power_per_texel[0][texel]);
  }
  const double most = *std::max_element(fractions.begin(), fractions.end());
  std::printf(
      "spot: texel powers / light power %.4f; inner-cone texel / mean %.3f; largest "
      "sum of a texel's fractions %.4f\n",
      sum / light, inner_share, most);
  EXPECT_GT(most, 0.8);  // the cube's texels keep most of their energy
  EXPECT_LE(most, 1.0 + 1e-4);
}

// The rules refuse what they cannot do, naming it.
TEST(AapsTrace, RefusesKeptPathsAndMissingDensities) {
  CornellGlass c;
  pb::trace::EmbreePhotonTracer tracer(c.world);
  AapsPhotons aaps_photons({});
  pb::trace::TraceSettings s = aaps_photons.settings();
  pb::trace::PhotonBatch batch;
  EXPECT_THROW(tracer.trace(s, batch), pb::InputError);  // no density set
  pb::trace::EmissionDensity odd{3, 3, std::vector<float>(9, 4.f)};
  aaps_photons.emission.set_counts({&odd});
  EXPECT_THROW(tracer.trace(s, batch), pb::InputError);  // not a power of two
  pb::trace::EmissionDensity ok{4, 4, std::vector<float>(16, 4.f)};
  aaps_photons.emission.set_counts({&ok});
  EXPECT_NO_THROW(tracer.trace(s, batch));
  s.keep_light_paths = true;
  EXPECT_THROW(tracer.trace(s, batch), pb::InputError);
}

fs::path work_dir(const std::string& name) { return pb::testing::work_dir("aaps_test", name); }

// The descriptor's check and the schema's choices, through the plan `photonbench validate` makes:
// each bad parameter is bad input reported at the config's file, line and column with the key at
// fault.
TEST(Aaps, RefusesBadParametersAtTheirKey) {
  fs::path dir = work_dir("check");
  const std::pair<const char*, const char*> cases[] = {
      {"density_resolution: 100", "density_resolution: 100 is not a power of two"},
      {"density_min: 8, density_max: 6", "density_max: 6 is below density_min = 8"},
      // An enumeration's unknown name, with the closest of its choices.
      {"msaa: smal_per_sample",
       "params.msaa: 'smal_per_sample' is not one of: none, all, all_per_sample, "
       "small_per_sample; did you mean 'small_per_sample'?"},
      {"feedback_halves: refraction",
       "params.feedback_halves: 'refraction' is not one of: both, refracted; did you mean "
       "'refracted'?"},
      {"indirect: splat", "params.indirect: 'splat' is not one of: none, splat_bvh"},
      {"indirect: splat_bvh, camera_bounces: 0",
       "params.camera_bounces: value 0 is out of range [1, 255]"},
      {"camera_bounces: 3", "camera_bounces: 3 has no effect with indirect = none"}};
  for (const auto& [params, message] : cases) {
    const std::string error = plan_error(dir, std::string("name: check\n"
                                                          "resolution: [64, 36]\n"
                                                          "scenes: [cornell-glass]\n"
                                                          "techniques:\n"
                                                          "  - technique: aaps\n"
                                                          "    params: {") +
                                                  params + "}\n");
    EXPECT_NE(error.find("config.yaml:6:"), std::string::npos) << params << ": " << error;
    EXPECT_NE(error.find(message), std::string::npos) << error;
  }
}

constexpr uint32_t kReferenceSamples = 64;
// AAPS's rules on cornell-glass (one convex dielectric): a photon that hits the sphere is reflected
// once (L S D) or refracted in and out (L S S D); the chained paths (an internal reflection, about
// a tenth of the caustic power here) are dropped by design (§1.5). The reference that holds exactly
// those paths is the caustics class truncated at 3 scattering vertices.
constexpr uint32_t kAapsPathVertices = 3;

struct Frames {
  int width, height, warmup, count, metrics_every;
  uint32_t reference_bounces = 0;  // 0: untruncated
};

// A config of cornell-glass and one aaps entry with `params` (a list sweeps), run in `dir`.
std::string aaps_config(const fs::path& dir, const Frames& f, const std::string& params) {
  return fmt::format(
      "name: aaps-test\n"
      "resolution: [{}, {}]\n"
      "seed: 1\n"
      "scenes: [cornell-glass]\n"
      "limits: {{cell_seconds: 300}}\n"
      "frames: {{warmup: {}, count: {}, metrics_every: {}}}\n"
      "metrics: [psnr]\n"
      "reference: {{samples: {}, max_bounces: {}, cache_dir: {}}}\n"
      "techniques:\n"
      "  - technique: aaps\n"
      "    params: {{{}}}\n",
      f.width, f.height, f.warmup, f.count, f.metrics_every, kReferenceSamples, f.reference_bounces,
      (dir / "refs").string(), params);
}

double image_sum(const pb::io::Image& image) {
  double sum = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int ch = 0; ch < 3; ++ch) sum += image.at(x, y, ch);
  return sum;
}

// The caustics reference of AAPS's paths summed over the screen, per measured frame (the run has
// rendered them into its cache).
std::vector<double> reference_sums(const fs::path& dir, const Frames& frames) {
  CornellGlass c;
  pb::trace::ReferenceCache cache(dir / "refs");
  pb::trace::ReferenceOptions options;
  options.samples = kReferenceSamples;
  options.max_bounces = kAapsPathVertices;
  std::vector<double> reference;
  for (int f = frames.warmup; f < frames.warmup + frames.count; ++f)
    reference.push_back(image_sum(cache.get_or_render(c.scene, c.scene.at(uint32_t(f)),
                                                      pb::trace::PathClass::caustics, frames.width,
                                                      frames.height, options)));
  return reference;
}

// The thesis's energy finding (§5.1.1) on the paths AAPS models: once the task buffer has
// converged, the caustics summed over the screen and over 8 frames match the reference's within 5%
// for the per-sample modes, and so does every single frame within 25%; `all` tests the ellipse at
// the pixel centre and keeps only the covered samples' share, and is dimmer. The caustic's focus is
// sub-pixel even at 256x192 (most of its energy lies in a few dozen pixels, drawn by splats far
// smaller than a pixel), so without MSAA a frame's energy depends on whether the focus falls on
// pixel centres: it swings from frame to frame as the orbiting light moves it, and its 8-frame
// mean is held to a bound fixed in advance, 15% (the aliasing §5.1 describes; the first version
// bounded it by three standard errors of its own frames, which a worse run widens).
TEST(Aaps, ScreenEnergyMatchesTheCausticsReference) {
  fs::path dir = work_dir("energy");
  const Frames frames{256, 192, 10, 8, 1, kAapsPathVertices};
  const char* modes[] = {"none", "all", "all_per_sample", "small_per_sample"};
  ASSERT_EQ(run_config(dir, aaps_config(dir, frames,
                                        "density_resolution: 32, target_area: 19, msaa: [none, "
                                        "all, all_per_sample, small_per_sample]")),
            0)
      << "see " << (dir / "log.txt");

  const std::vector<double> reference = reference_sums(dir, frames);
  const double reference_sum = std::accumulate(reference.begin(), reference.end(), 0.0);
  ASSERT_GT(reference_sum, 0);
  std::map<std::string, double> ratio, standard_error;
  for (const char* mode : modes) {
    fs::path cell = find_cell(dir, "aaps", {{"msaa", mode}});
    ASSERT_FALSE(cell.empty()) << mode;
    auto record = read_json(cell / "cell.json");
    EXPECT_EQ(record["status"], "ok") << record.dump();
    EXPECT_EQ(record["validation"], validation_on());
    double sum = 0, square_sum = 0;
    std::string per_frame;
    const bool per_sample = std::string(mode).find("per_sample") != std::string::npos;
    for (int i = 0; i < frames.count; ++i) {
      double frame_sum = image_sum(frame_image(cell, frames.warmup + i, "caustics"));
      double r = frame_sum / reference[size_t(i)];
      sum += frame_sum, square_sum += r * r;
      per_frame += fmt::format(" {:.3f}", r);
      if (per_sample) EXPECT_NEAR(r, 1.0, 0.25) << mode << " frame " << frames.warmup + i;
    }
    ratio[mode] = sum / reference_sum;
    double mean_square = square_sum / frames.count;
    double frame_mean = ratio[mode];  // close to the mean of the per-frame ratios
    standard_error[mode] =
        std::sqrt(std::max(0.0, mean_square - frame_mean * frame_mean) / double(frames.count - 1));
    std::printf("msaa %-16s screen caustics / reference = %.4f (+- %.3f; frames%s)\n", mode,
                ratio[mode], standard_error[mode], per_frame.c_str());
  }
  EXPECT_NEAR(ratio["all_per_sample"], 1.0, 0.05);
  EXPECT_NEAR(ratio["small_per_sample"], 1.0, 0.05);
  EXPECT_NEAR(ratio["none"], 1.0, 0.15);
  EXPECT_LT(ratio["all"], ratio["none"] - 0.05);
}

// Issue 25's frame-by-frame energy at 160x90 (warm-up 8, frames 8-13, the shipped density 256^2):
// the per-sample modes' screen caustics within 25% of the reference in every frame, their mean
// within 10%. The focus is sub-pixel here, drawn by splats far smaller than a sample; at cell
// centres (emission_jitter false) the emission grid maps to a regular lattice of them that slides
// over the sample grid as the light orbits, so a frame's energy swung 0.85-1.55 per sample (and
// 0.62-1.67 without MSAA). The bounds are the issue's, fixed; the reference's own error on a
// frame's sum is about 1% (its two halves differ by 2%).
TEST(Aaps, CausticPowerFrameByFrameAt160x90) {
  fs::path dir = work_dir("frames");
  const Frames frames{160, 90, 8, 6, 1, kAapsPathVertices};
  ASSERT_EQ(run_config(dir, aaps_config(dir, frames,
                                        "msaa: [none, all_per_sample, "
                                        "small_per_sample]")),
            0)
      << "see " << (dir / "log.txt");
  const std::vector<double> reference = reference_sums(dir, frames);
  for (const char* mode : {"none", "all_per_sample", "small_per_sample"}) {
    fs::path cell = find_cell(dir, "aaps", {{"msaa", mode}});
    ASSERT_FALSE(cell.empty()) << mode;
    std::vector<double> ratio;
    std::string per_frame;
    for (int i = 0; i < frames.count; ++i) {
      ratio.push_back(image_sum(frame_image(cell, frames.warmup + i, "caustics")) /
                      reference[size_t(i)]);
      per_frame += fmt::format(" {:.3f}", ratio.back());
    }
    double mean = std::accumulate(ratio.begin(), ratio.end(), 0.0) / double(ratio.size());
    std::printf("msaa %-16s 160x90 caustics / reference per frame:%s; mean %.3f\n", mode,
                per_frame.c_str(), mean);
    if (std::string(mode) == "none") continue;  // aliased by design (§5.1): printed, not bounded
    for (size_t i = 0; i < ratio.size(); ++i)
      EXPECT_NEAR(ratio[i], 1.0, 0.25) << mode << " frame " << frames.warmup + int(i);
    EXPECT_NEAR(mean, 1.0, 0.10) << mode;
  }
}

// §5.1.2's per-sample depth test against the single-sample G-buffer: a sample off the pixel centre
// is compared with the receiver's tangent plane met along its own ray, not with the centre's
// distance, whose error (depth gradient x offset) exceeds the 1% margin on cornell-glass's floor at
// 128x96. So tightening the margin from 5% to 1% drops per sample about what it drops at pixel
// rate, what the sphere hides near its foot (measured: pixel rate keeps 0.968 of the energy, per
// sample 0.939; with the centre's distance per sample kept 0.576).
TEST(Aaps, PerSampleDepthTestFollowsTheReceiver) {
  fs::path dir = work_dir("depth");
  ASSERT_EQ(run_config(dir, aaps_config(dir, {128, 96, 10, 1, 0},
                                        "density_resolution: 32, msaa: [none, all_per_sample], "
                                        "depth_margin: [0.01, 0.05]")),
            0)
      << "see " << (dir / "log.txt");
  std::map<std::string, double> kept;
  for (const char* mode : {"none", "all_per_sample"}) {
    std::map<std::string, double> energy;
    for (const char* margin : {"0.01", "0.05"}) {
      fs::path cell = find_cell(dir, "aaps", {{"msaa", mode}, {"depth_margin", margin}});
      ASSERT_FALSE(cell.empty()) << mode << " " << margin;
      energy[margin] = counters(cell)["caustic_energy"];
    }
    ASSERT_GT(energy["0.05"], 0);
    kept[mode] = energy["0.01"] / energy["0.05"];
    std::printf("%s caustic energy, margin 1%% / 5%%: %.4f\n", mode, kept[mode]);
  }
  EXPECT_GT(kept["all_per_sample"], kept["none"] - 0.05);
}

// §3.3.5's culling, by a splat's solid angle from the light sized for one fixed sampling (the
// thesis's base 1/512 of the emission parameter): its thresholds cull a share that falls as they
// rise, from everything at a vanishing threshold to nothing at 1 sr, and the lowest it tested
// (0.0014 sr) culls the larger splats, not all (measured on frame 0, before any feedback: 46%,
// 0.01 sr 7%; sized at one unit of the parameter, 0.0014 sr culled all).
TEST(Aaps, CullingThresholdsMeanWhatTheThesisTested) {
  fs::path dir = work_dir("culling");
  ASSERT_EQ(run_config(dir, aaps_config(dir, {128, 96, 0, 1, 0},
                                        "density_resolution: 32, cull_solid_angle: [0, 1e-9, "
                                        "0.0014, 0.01, 1]")),
            0)
      << "see " << (dir / "log.txt");
  auto culled = [&](const char* threshold) {
    fs::path cell = find_cell(dir, "aaps", {{"cull_solid_angle", threshold}});
    EXPECT_FALSE(cell.empty()) << threshold;
    return counters(cell);
  };
  // Frame 0 emits the same photons in every cell: what cull_solid_angle 0 culls is the frustum's.
  const auto none = culled("0");
  const double frustum = none.at("photons_culled"), splats = none.at("photons_recorded") - frustum;
  ASSERT_GT(splats, 50);
  auto share = [&](const char* threshold) {
    return (culled(threshold).at("photons_culled") - frustum) / splats;
  };
  std::printf("culled share: 1e-9 sr %.3f, 0.0014 sr %.3f, 0.01 sr %.3f, 1 sr %.3f\n",
              share("1e-09"), share("0.0014"), share("0.01"), share("1"));
  EXPECT_EQ(share("1e-09"), 1.0);
  EXPECT_GT(share("0.0014"), share("0.01"));
  EXPECT_LT(share("0.0014"), 0.9);
  EXPECT_GT(share("0.01"), 0.0);
  EXPECT_LT(share("1"), 0.01);
}

// §5.1.3's split and §4.5.2's non-contributing share, on frame 0 (every cell emits the same
// photons: the task buffer is uniform before any feedback). small_per_sample at threshold 0 sends
// no splat to the multisampled list and draws exactly what `none` draws; at a threshold above
// every splat it sends them all and draws exactly what all_per_sample draws; at 2 px^2 it sends
// most tiny splats and no large one. The share of splats that reach no pixel centre or sample:
// near zero for splats of tens of pixels (footprint_scale 5, no depth rejection), most of them for
// splats far below a pixel (footprint_scale 0.05), and fewer per sample than at the pixel centre
// there.
TEST(Aaps, SmallPerSampleSplitAndNonContributingShare) {
  fs::path dir = work_dir("split");
  ASSERT_EQ(run_config(dir, aaps_config(dir, {128, 96, 0, 1, 0},
                                        "density_resolution: 32, depth_margin: 1, "
                                        "footprint_scale: [0.05, 5], msaa: [none, all_per_sample, "
                                        "small_per_sample], msaa_threshold: [0, 2, 1000000]")),
            0)
      << "see " << (dir / "log.txt");
  auto cell = [&](const char* scale, const char* mode, const char* threshold) {
    fs::path c = find_cell(
        dir, "aaps", {{"footprint_scale", scale}, {"msaa", mode}, {"msaa_threshold", threshold}});
    EXPECT_FALSE(c.empty()) << scale << " " << mode << " " << threshold;
    return counters(c);
  };
  for (const char* scale : {"0.05", "5"}) {
    SCOPED_TRACE(scale);
    auto none = cell(scale, "none", "2"), all = cell(scale, "all_per_sample", "2");
    auto zero = cell(scale, "small_per_sample", "0"), two = cell(scale, "small_per_sample", "2"),
         every = cell(scale, "small_per_sample", "1000000");
    const double splats = none.at("splats_drawn");
    ASSERT_GT(splats, 50);
    EXPECT_EQ(zero.at("splats_per_sample"), 0);
    EXPECT_EQ(zero.at("caustic_energy"), none.at("caustic_energy"));
    EXPECT_EQ(zero.at("splats_noncontributing"), none.at("splats_noncontributing"));
    EXPECT_EQ(every.at("splats_per_sample"), splats);
    EXPECT_NEAR(every.at("caustic_energy") / all.at("caustic_energy"), 1, 1e-5);
    EXPECT_EQ(every.at("splats_noncontributing"), all.at("splats_noncontributing"));
    std::printf(
        "footprint_scale %s: per-sample share at 2 px^2 %.3f; non-contributing none %.3f, "
        "all_per_sample %.3f\n",
        scale, two.at("splats_per_sample") / splats, none.at("noncontributing_share"),
        all.at("noncontributing_share"));
    if (std::string(scale) == "0.05") {
      // Most far below 2 px^2 (those clamped in anisotropy grow).
      EXPECT_GT(two.at("splats_per_sample"), 0.5 * splats);
      EXPECT_GT(none.at("noncontributing_share"), 0.5);
      EXPECT_LT(all.at("noncontributing_share"), none.at("noncontributing_share"));
    } else {
      EXPECT_LT(two.at("splats_per_sample"), 0.5 * splats);
      EXPECT_LT(none.at("noncontributing_share"), 0.05);
      EXPECT_LT(all.at("noncontributing_share"), 0.05);
    }
  }
}

// §1.4 / §1.10: the sphere covers under 2% of the point light's directions, so a uniform task
// buffer records few of its photons; the feedback moves density onto the texels whose photons land
// on screen, and the recorded share of emitted photons rises over the first frames and stays up.
TEST(Aaps, DensityConcentratesOnTheCaustic) {
  fs::path dir = work_dir("adaptivity");
  ASSERT_EQ(run_config(dir, aaps_config(dir, {128, 96, 0, 12, 12},
                                        "density_resolution: 16, target_area: 1")),
            0)
      << "see " << (dir / "log.txt");
  fs::path cell = find_cell(dir, "aaps");
  ASSERT_FALSE(cell.empty());
  std::vector<double> share = counter_series(cell, "recorded_share");
  ASSERT_EQ(share.size(), 12u);
  for (double s : share) std::printf("%.4f ", s);
  std::printf("\n");
  for (size_t f = 6; f < share.size(); ++f) EXPECT_GT(share[f], 3 * share[0]) << "frame " << f;
}

// ---- indirect: splat_bvh (§5.2) ----

// The ellipse test the fragment shader and the walk's any-hit share (splat_bvh.h), on points
// uniform in random splats' quads: it rejects the quad's corners, 1 - pi/4 of its area (§5.2:
// "the ellipse covers pi/4 of the quad"), within 4 binomial deviations of the count. Each point
// also comes back through aaps_plane_crossing from a segment that crosses the splat's plane.
TEST(AapsSplatBvh, EllipseTestRejectsTheQuadsCornerShare) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(-1.f, 1.f);
  constexpr int kSplats = 200, kPointsPerSplat = 1000;
  uint64_t rejected = 0, total = 0;
  for (int i = 0; i < kSplats; ++i) {
    aaps::SplatRecord s{};
    s.centre = glm::vec3(unit(rng), unit(rng), unit(rng)) * 3.f;
    s.major = glm::normalize(glm::vec3(unit(rng), unit(rng), unit(rng))) *
              (0.01f + 0.2f * (1 + unit(rng)));
    const glm::vec3 side =
        glm::normalize(glm::cross(s.major, glm::vec3(unit(rng), unit(rng), unit(rng))));
    s.minor = side * glm::length(s.major) * (0.1f + 0.45f * (1 + unit(rng)));
    const glm::vec3 normal = glm::normalize(glm::cross(s.major, s.minor));
    for (int k = 0; k < kPointsPerSplat; ++k) {
      const float u = unit(rng), v = unit(rng);
      const glm::vec3 x = s.centre + u * s.major + v * s.minor;
      // A segment from 0.5 m off the plane, slanted, crossing it at x.
      const glm::vec3 d = glm::normalize(-normal + 0.5f * glm::normalize(s.major));
      const glm::vec3 origin = x - 0.5f * d;
      const float t = aaps::aaps_plane_crossing(s, origin, d);
      ASSERT_NEAR(t, 0.5f, 1e-4f);
      const glm::vec2 bary = aaps::aaps_quad_bary(s, origin + t * d);
      ASSERT_NEAR(bary.x, u, 1e-3f);
      ASSERT_NEAR(bary.y, v, 1e-3f);
      rejected += aaps::aaps_in_ellipse(bary) ? 0 : 1;
      ++total;
    }
  }
  const double p = 1.0 - M_PI / 4.0;
  const double rate = double(rejected) / double(total);
  const double sigma = std::sqrt(p * (1 - p) / double(total));
  std::printf("rejected %.5f of %llu points, 1 - pi/4 = %.5f, sigma %.5f\n", rate,
              static_cast<unsigned long long>(total), p, sigma);
  EXPECT_NEAR(rate, p, 4 * sigma);
}

// collection-points' mirror scene (its test's), with the caustic made the way AAPS makes one: a
// photon whose first hit is not a dielectric is dropped (§1.5), so the light, travelling straight
// down with E = 2 W/m^2, crosses a horizontal glass slab (ior 1.5, y in [2, 2.2]) over the floor
// (albedo 0.5) before landing. At normal incidence each interface passes 1 - F0 = 0.96 (the split's
// refracted part, then the repeated refraction weighted by its Fresnel share), so the floor under
// the slab receives the caustic irradiance E_c = 0.96^2 E (L S S D) and, seen directly, sends
// 0.5 / pi E_c. The camera at (0, 1, 0), below the slab, sees only a vertical mirror (specular
// 0.9) at x = 1 facing -x, and in it only that floor: every pixel's camera path is E S D with
// throughput 0.9, so indirect_caustics is 0.9 (the mirror's tint) x the direct view's caustic
// everywhere, and the directly seen caustics estimate is 0.
constexpr const char* kMirrorScene =
    R"(purpose: a glass slab's caustic seen in a mirror (techniques/aaps/tests)
camera: {position: [0, 1, 0], target: [1, 0.5, 0], fov_deg: 30}
lights:
  - {name: sun, type: directional, direction: [0, -1, 0], irradiance: 2}
materials:
  grey: {type: diffuse, albedo: [0.5, 0.5, 0.5]}
  mirror: {type: mirror, specular: 0.9}
  glass: {type: dielectric, ior: 1.5}
objects:
  - {name: floor, shape: {type: quad, size: [6, 6]}, material: grey,
     transform: {translate: [-2, 0, 0]}}
  - {name: mirror, shape: {type: quad, size: [4, 6]}, material: mirror,
     transform: {translate: [1, 2, 0], rotate_deg: [0, 0, 90]}}
  - {name: slab, shape: {type: box, size: [5.99, 0.2, 6]}, material: glass,
     transform: {translate: [-2.005, 2.1, 0]}}
)";
constexpr double kMirrorTint = 0.9;
constexpr double kFresnelPass = 1.0 - 0.04;  // 1 - ((1.5 - 1) / (1.5 + 1))^2
constexpr double kDirectViewCaustic = 0.5 / M_PI * kFresnelPass * kFresnelPass * 2.0;

double mean_channel(const pb::io::Image& image, int channel) {
  double sum = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) sum += image.at(x, y, channel);
  return sum / image.pixel_count();
}

// Frames 0 and 2 scored (not consecutive: the flicker of the black caustics reference is refused).
// Here a splat is far smaller than the floor a pixel sees in the mirror (1 cm against 2-5 cm),
// so each pixel is an independent point sample of the covering splats, and the image mean's
// relative deviation is at most Poisson's over the frame's covering splats (the jittered grid is
// stratified, so less): the mean is the direct view's caustic times the mirror's tint within
// 4 / sqrt(segment hits of a frame) + 1%. Every pixel walks, no walk is cut short, and the
// crossings inside a quad fall outside its ellipse 1 - pi/4 of the time within 4 binomial
// deviations of their count (the splats lie anywhere against the pixels' points).
TEST(AapsRun, SplatBvhSeesTheMirrorsCausticTimesItsTint) {
  fs::path dir = work_dir("mirror");
  std::ofstream(dir / "scene.yaml") << kMirrorScene;
  ASSERT_EQ(run_config(dir, fmt::format("name: aaps-mirror\nresolution: [64, 48]\nseed: 1\n"
                                        "scenes: [{}]\nframes: {{warmup: 0, count: 3, "
                                        "metrics_every: 2}}\nmetrics: [psnr]\n"
                                        "limits: {{cell_seconds: 300}}\n"
                                        "reference: {{samples: 2, cache_dir: {}}}\n"
                                        "techniques:\n  - technique: aaps\n"
                                        "    params: {{indirect: splat_bvh, max_bounces: 3}}\n",
                                        (dir / "scene.yaml").string(), (dir / "refs").string())),
            0)
      << "see " << (dir / "log.txt");
  fs::path cell = find_cell(dir, "aaps");
  ASSERT_FALSE(cell.empty());
  EXPECT_EQ(read_json(cell / "cell.json")["status"], "ok");
  const CounterSums sums(cell);
  EXPECT_EQ(sums["indirect_walks"], 3.0 * 64 * 48) << "every pixel sees the floor in the mirror";
  EXPECT_EQ(sums["truncated_walks"], 0);
  EXPECT_GT(sums["ellipse_rejections"], 0);
  EXPECT_GT(sums["bvh_nodes"], 0);
  const double in_quad = sums["segment_hits"] + sums["ellipse_rejections"];
  const double p = 1 - M_PI / 4, share = sums["ellipse_rejections"] / in_quad;
  std::printf("ellipse rejections %.0f of %.0f crossings in a quad: %.4f (1 - pi/4 = %.4f)\n",
              sums["ellipse_rejections"], in_quad, share, p);
  EXPECT_NEAR(share, p, 4 * std::sqrt(p * (1 - p) / in_quad));
  const double hits_per_frame = sums["segment_hits"] / 3;
  const double tolerance = 4.0 / std::sqrt(hits_per_frame) + 0.01;
  for (int frame : {0, 2}) {
    const double mean = mean_channel(frame_image(cell, frame, "indirect_caustics"), 0);
    const double expected = kMirrorTint * kDirectViewCaustic;
    std::printf(
        "frame %d: mean %.5f, tint x direct view %.5f (%.0f hits a frame, tolerance %.3f)\n", frame,
        mean, expected, hits_per_frame, tolerance);
    EXPECT_NEAR(mean / expected, 1.0, tolerance) << "frame " << frame;
    EXPECT_EQ(mean_channel(frame_image(cell, frame, "caustics"), 0), 0.0)
        << "no caustic is seen directly";
  }
  fs::remove_all(dir);
}

}  // namespace aaps_test
