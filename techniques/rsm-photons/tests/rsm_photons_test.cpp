// rsm-photons: the CPU halves on hand-built inputs (the Haar transform, the warped Hammersley
// points against the map by a chi-square test, the probability map's zeros outside the near/far
// range and Eq. 4.9, the kernel, each filter against a closed form), then end to end through
// `photonbench`: bad parameters refused at their key, and the screen's indirect light against its
// reference.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "../rsm_core.h"
#include "io/image.h"
#include "reference/reference.h"
#include "run_fixture.h"
#include "scene/scene.h"

namespace fs = std::filesystem;

namespace rsm_photons_test {

using namespace pb::testing;

// A 16 x 16 map with every case the warping meets: zeros (whole quads too), a bright texel, a
// smooth ramp.
std::vector<float> test_map(uint32_t side) {
  std::vector<float> m(size_t(side) * side);
  for (uint32_t y = 0; y < side; ++y)
    for (uint32_t x = 0; x < side; ++x) m[y * side + x] = 0.1f + float(x + 2 * y) / float(side);
  for (uint32_t y = 0; y < 4; ++y)
    for (uint32_t x = 0; x < 4; ++x) m[y * side + x] = 0;  // a zero quad two levels up
  m[5 * side + 9] = 0;
  m[12 * side + 3] = 25;  // a hot texel
  return m;
}

// §5.3.1: the transform's coarsest scaling coefficient is the map's mean (P0 of §5.3.3) and the
// inverse transform gives the map back.
TEST(RsmPhotonsSampling, HaarTransformInvertsAndItsRootIsTheMean) {
  const uint32_t side = 16;
  const std::vector<float> map = test_map(side);
  rsm::HaarPyramid pyramid(map, side);
  EXPECT_EQ(pyramid.levels(), 5u);
  const double mean = std::accumulate(map.begin(), map.end(), 0.0) / double(map.size());
  EXPECT_NEAR(pyramid.mean(), mean, 1e-5 * mean);
  const std::vector<float> back = pyramid.reconstruct();
  ASSERT_EQ(back.size(), map.size());
  for (size_t i = 0; i < map.size(); ++i) EXPECT_NEAR(back[i], map[i], 1e-5f) << "texel " << i;
}

// §5.3.2: Hammersley points warped through the pyramid land in each texel in proportion to its
// value (chi-square over the 239 non-zero texels: 65,536 points, 238 degrees of freedom, the 0.1%
// critical value 311 (Wilson-Hilferty); the points are stratified, not independent, so the
// statistic comes out far below its degrees of freedom), never in a zero texel, inside the texel
// they report, with the density P / mean(P); and inside every texel they are spread evenly (each
// quarter of the hot texel gets its share).
TEST(RsmPhotonsSampling, WarpedHammersleyPointsFollowTheMap) {
  const uint32_t side = 16, n = 65536;
  const std::vector<float> map = test_map(side);
  rsm::HaarPyramid pyramid(map, side);
  const double total = std::accumulate(map.begin(), map.end(), 0.0);
  std::vector<double> count(map.size(), 0.0);
  double quarter[4] = {0, 0, 0, 0};
  for (uint32_t i = 0; i < n; ++i) {
    const rsm::HaarPyramid::Sample s = pyramid.warp(rsm::hammersley(i, n, {0.37f, 0.61f}));
    ASSERT_LT(s.texel, map.size());
    const uint32_t x = uint32_t(s.uv.x * side), y = uint32_t(s.uv.y * side);
    ASSERT_EQ(y * side + x, s.texel);
    EXPECT_NEAR(s.density, map[s.texel] / (total / map.size()), 1e-4);
    count[s.texel] += 1;
    if (s.texel == 12 * side + 3) {
      const glm::vec2 local = s.uv * float(side) - glm::vec2(3, 12);
      quarter[(local.x >= 0.5f ? 1 : 0) + (local.y >= 0.5f ? 2 : 0)] += 1;
    }
  }
  double chi2 = 0;
  int dof = -1;
  for (size_t t = 0; t < map.size(); ++t) {
    if (map[t] == 0) {
      EXPECT_EQ(count[t], 0) << "zero texel " << t;
      continue;
    }
    const double expected = n * map[t] / total;
    chi2 += (count[t] - expected) * (count[t] - expected) / expected;
    ++dof;
  }
  std::printf("chi-square %.1f over %d degrees of freedom\n", chi2, dof);
  EXPECT_EQ(dof, 238);
  EXPECT_LT(chi2, 311.0);
  const double hot = count[12 * side + 3];
  for (double q : quarter) EXPECT_NEAR(q / hot, 0.25, 0.02);
}

// §5.2 and Eq. 4.9: a texel's probability is max_c(rho_c Phi_c) / max_c(Phi_c) times the falloff
// (the incident power's mean), zero outside [near, far] and where the ray met nothing; a texel no
// ray reached gets the mean of those that were reached.
TEST(RsmPhotonsSampling, ProbabilityMapIsZeroOutsideTheNearFarRange) {
  const glm::vec3 incident{1.f, 0.5f, 0.25f}, rho{0.8f, 0.2f, 0.1f};
  EXPECT_NEAR(rsm::survival(rho, incident), 0.8f, 1e-6);  // max(0.8, 0.1, 0.025) / 1
  EXPECT_NEAR(rsm::survival({0.1f, 0.9f, 0.1f}, incident), 0.45f, 1e-6);
  std::vector<rsm::RsmTexel> texels(8);
  const float distances[8] = {0.5f, 0.99f, 1.f, 1.5f, 2.f, 2.01f, 3.f, 1.5f};
  for (int i = 0; i < 8; ++i) {
    texels[i].sampled = texels[i].hit = true;
    texels[i].distance = distances[i];
    texels[i].incident = incident * float(i + 1);
    texels[i].reflectance = rho;
  }
  texels[6].sampled = false;  // no ray: gets the mean
  texels[7].hit = false;      // the ray left the scene
  const std::vector<float> p = rsm::probability_map(texels, 1.f, 2.f);
  const float falloff = rsm::mean3(incident);
  EXPECT_EQ(p[0], 0.f);
  EXPECT_EQ(p[1], 0.f);
  EXPECT_NEAR(p[2], 0.8f * falloff * 3, 1e-5);
  EXPECT_NEAR(p[3], 0.8f * falloff * 4, 1e-5);
  EXPECT_NEAR(p[4], 0.8f * falloff * 5, 1e-5);
  EXPECT_EQ(p[5], 0.f);
  EXPECT_EQ(p[7], 0.f);
  EXPECT_NEAR(p[6], (p[2] + p[3] + p[4]) / 7, 1e-5);  // the mean over the 7 sampled texels
}

// §6.1: a photon arriving 60 degrees off the normal gets s_u = 2, the tile radius of Eq. 6.2
// (clamped, times n_tile), the ray-length scale of Eq. 6.1 with RTG's 0.1 floor, the normal axis
// s_n times the rest, and E = Phi / (pi |u| |t|); its ellipsoid holds the points Eq. 6.5 says.
TEST(RsmPhotonsKernel, EllipsoidFollowsEquations61To66) {
  rsm::KernelParams k;
  k.n_tile = 1.5f, k.r_min = 0.001f, k.r_max = 1.f, k.l_max = 2.f, k.s_n = 0.25f, k.s_max = 5.f;
  const float c_tile = rsm::tile_constant(0.7f, 320, 180, 16);
  EXPECT_NEAR(c_tile, std::tan(0.35f) * std::tan(0.35f) * 320.f / 180.f * 256.f / 57600.f, 1e-9);
  const glm::vec3 n{0, 1, 0};
  const glm::vec3 direction = -glm::vec3(std::sin(1.0472f), std::cos(1.0472f), 0.f);
  const float z = 2.f, l = 1.f;
  const uint32_t photons = 40;
  const rsm::Kernel kernel =
      rsm::make_kernel({1, 0, 0}, n, direction, {3, 3, 3}, l, z, photons, c_tile, k);
  const float r = std::sqrt(z * z * c_tile / (rsm::kPi * photons));
  const float s = r * k.n_tile * (l / k.l_max);
  EXPECT_NEAR(kernel.t_length, s, 1e-6);
  EXPECT_NEAR(kernel.u_length, 2 * s, 1e-4 * s);
  EXPECT_NEAR(kernel.n_length, k.s_n * s, 1e-6);
  EXPECT_NEAR(glm::dot(kernel.u, glm::vec3(1, 0, 0)), 1, 1e-5);  // towards the light, projected
  EXPECT_NEAR(kernel.irradiance.x, 3 / (rsm::kPi * kernel.u_length * kernel.t_length), 1e-3);
  EXPECT_TRUE(rsm::inside(kernel, {1, 0, 0}));
  EXPECT_TRUE(rsm::inside(kernel, glm::vec3(1, 0, 0) + 0.99f * kernel.u_length * kernel.u));
  EXPECT_FALSE(rsm::inside(kernel, glm::vec3(1, 0, 0) + 1.01f * kernel.u_length * kernel.u));
  EXPECT_FALSE(rsm::inside(kernel, glm::vec3(1, 0, 0) + 1.01f * kernel.t_length * kernel.t));
  EXPECT_FALSE(rsm::inside(kernel, glm::vec3(1, 0, 0) + 1.01f * kernel.n_length * kernel.n));
  // A short ray: the 0.1 floor; an empty tile: r = 0.1 m.
  const rsm::Kernel short_ray =
      rsm::make_kernel({0, 0, 0}, n, -n, {1, 1, 1}, 0.001f, z, photons, c_tile, k);
  EXPECT_NEAR(short_ray.t_length, r * k.n_tile * 0.1f, 1e-6);
  const rsm::Kernel empty = rsm::make_kernel({0, 0, 0}, n, -n, {1, 1, 1}, l, z, 0, c_tile, k);
  EXPECT_NEAR(empty.t_length, 0.1f * k.n_tile * 0.5f, 1e-6);
}

// A view of a plane z = -depth_at(x) (a slanted floor, so the depth gradient is not zero), every
// normal (0, 0, 1); `step` > 0 puts the right half `step` metres farther (a depth edge).
rsm::Geometry plane(int width, int height, float step = 0) {
  rsm::Geometry g;
  g.width = width, g.height = height;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float depth = 2.f + 0.01f * float(y) + (x >= width / 2 ? step : 0.f);
      g.position.push_back({0.01f * float(x), 0.01f * float(y), -depth, depth});
      g.normal.push_back({0, 0, 1, 0});
    }
  return g;
}

// §7: the chain leaves a constant image constant (each stage is a normalised weighted mean; a
// constant has no detail), whatever the weights.
TEST(RsmPhotonsFilters, ChainLeavesAConstantImageConstant) {
  const rsm::Geometry g = plane(40, 24);
  rsm::FilterParams f;
  const glm::vec3 c{0.3f, 0.5f, 0.7f};
  std::vector<glm::vec3> e(g.position.size(), c), dir(g.position.size(), glm::vec3(0, 1, 0));
  rsm::History h;
  h.valid = true;
  h.geometry = g;
  h.view_projection = glm::mat4(1.f);  // a point (x, y, z) maps to NDC (x, y)
  h.irradiance = e;
  h.direction = dir;
  rsm::temporal(g, h, f, e, dir);
  rsm::atrous(g, f, e, dir);
  for (size_t i = 0; i < e.size(); ++i) {
    ASSERT_NEAR(e[i].x, c.x, 1e-5) << i;
    ASSERT_NEAR(e[i].y, c.y, 1e-5) << i;
    ASSERT_NEAR(e[i].z, c.z, 1e-5) << i;
  }
  // The bilinear upsampling too.
  std::vector<glm::vec3> small(20 * 12, c);
  for (const glm::vec3& v : rsm::upsample(small, 20, 12, 40, 24, 2)) ASSERT_NEAR(v.y, c.y, 1e-6);
}

// The pair of the test above, which a filter doing nothing passes too: on the same plane (no edge:
// every w_z and w_n is 1) an image of independent noise about a mean comes out of the a-trous chain
// with that mean (to 1%) and its spread cut at least tenfold (four iterations of the B3 kernel,
// 2^i apart, with the clipped details' small remainder: 0.577 to 0.050 measured, 0.086 of it; a
// filter doing nothing keeps all of it); and the bilinear upsampling of a ramp gives each interior
// full-resolution pixel the ramp's value at its centre (a nearest-neighbour copy is 1/4 step off).
TEST(RsmPhotonsFilters, ChainSmoothsNoiseAndUpsamplesARamp) {
  const rsm::Geometry g = plane(64, 48);
  const size_t n = g.position.size();
  std::mt19937 random(7);
  std::uniform_real_distribution<float> noise(0.f, 2.f);
  std::vector<glm::vec3> e(n), dir(n, glm::vec3(0, 1, 0));
  for (glm::vec3& v : e) v = glm::vec3(noise(random));
  auto mean_and_spread = [&](const std::vector<glm::vec3>& image) {
    double sum = 0, squares = 0;
    for (const glm::vec3& v : image) sum += v.x, squares += double(v.x) * v.x;
    const double mean = sum / double(image.size());
    return std::pair{mean, std::sqrt(std::max(0.0, squares / double(image.size()) - mean * mean))};
  };
  const auto [mean_in, spread_in] = mean_and_spread(e);
  rsm::FilterParams f;
  rsm::atrous(g, f, e, dir);
  const auto [mean_out, spread_out] = mean_and_spread(e);
  std::printf("a-trous on noise: mean %.4f -> %.4f, spread %.4f -> %.4f\n", mean_in, mean_out,
              spread_in, spread_out);
  EXPECT_NEAR(mean_out, mean_in, 0.01 * mean_in);
  EXPECT_LT(spread_out, 0.1 * spread_in);
  // The upsampling of a ramp along x (value = the small pixel's x).
  const int small_width = 20, small_height = 12;
  std::vector<glm::vec3> ramp(size_t(small_width) * small_height);
  for (int y = 0; y < small_height; ++y)
    for (int x = 0; x < small_width; ++x) ramp[size_t(y) * small_width + x] = glm::vec3(float(x));
  const std::vector<glm::vec3> up = rsm::upsample(ramp, small_width, small_height, 40, 24, 2);
  for (int y = 0; y < 24; ++y)
    for (int x = 1; x < 39; ++x)
      ASSERT_NEAR(up[size_t(y) * 40 + x].x, (float(x) + 0.5f) / 2 - 0.5f, 1e-5) << x << "," << y;
}

// Eq. 7.3-7.4 on a static view: alpha = alpha_max where the history's depth and normal agree (w_z =
// w_n = 1), so n frames of E = 1 from an empty history give 1 - alpha^n; a history whose normals
// are turned 90 degrees has w_n = 0 and is ignored (S = E); one at 10 times the depth tolerance has
// w_z = e^-10.
TEST(RsmPhotonsFilters, TemporalBlendFollowsItsGeometricWeights) {
  const int width = 32, height = 16;
  rsm::Geometry g = plane(width, height);
  // A camera at the origin looking down -z whose NDC is (x, y) / (w * 0.16, h * 0.16) ... in
  // effect: the identity keeps NDC = (x, y), so pixel (px, py) must hold a point at NDC of its
  // centre. Place the points there.
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      glm::vec4& p = g.position[size_t(y) * width + x];
      p.x = (float(x) + 0.5f) / float(width) * 2 - 1;
      p.y = (float(y) + 0.5f) / float(height) * 2 - 1;
    }
  rsm::FilterParams f;
  f.alpha_max = 0.95f;
  rsm::History h;
  h.valid = true;
  h.geometry = g;
  h.view_projection = glm::mat4(1.f);
  h.camera = glm::vec3(0.f);
  // The stored distance must be the distance from the history's camera.
  for (auto& p : h.geometry.position) p.w = glm::length(glm::vec3(p));
  for (auto& p : g.position) p.w = glm::length(glm::vec3(p));
  const size_t n = size_t(width) * height;
  h.irradiance.assign(n, glm::vec3(0.f));
  h.direction.assign(n, glm::vec3(0.f));
  std::vector<glm::vec3> e, dir;
  for (int frame = 1; frame <= 5; ++frame) {
    e.assign(n, glm::vec3(1.f));
    dir.assign(n, glm::vec3(0, 0, 1));
    rsm::temporal(g, h, f, e, dir);
    h.irradiance = e;
    h.direction = dir;
    for (size_t i = 0; i < n; ++i)
      ASSERT_NEAR(e[i].x, 1 - std::pow(0.95, frame), 1e-5) << "frame " << frame << " pixel " << i;
  }
  rsm::History turned = h;
  for (auto& nn : turned.geometry.normal) nn = {1, 0, 0, 0};
  e.assign(n, glm::vec3(0.5f));
  rsm::temporal(g, turned, f, e, dir);
  for (size_t i = 0; i < n; ++i) ASSERT_NEAR(e[i].x, 0.5f, 1e-6);
  rsm::History farther = h;
  farther.irradiance.assign(n, glm::vec3(0.f));
  for (auto& p : farther.geometry.position) p.w *= 1.1f;  // 10 x epsilon (0.01 of the depth)
  e.assign(n, glm::vec3(1.f));
  rsm::temporal(g, farther, f, e, dir);
  const size_t centre = size_t(height / 2) * width + width / 2;
  const float zp = g.position[centre].w;
  const float alpha = 0.95f * std::exp(-(0.1f * zp) / (0.01f * zp + 1e-9f)) * 1.f;
  EXPECT_NEAR(e[centre].x, 1 - alpha, 2e-3);
}

// §7.3.1 and the sign of Eq. 7.8: with gamma 0 no detail survives (the result is S_N, the a-trous
// smoothing alone); with gamma large every detail is kept and the details telescope back to the
// input, S_N + sum D_i = S_0 exactly.
TEST(RsmPhotonsFilters, DetailClipSpansTheSmoothedAndTheInputImage) {
  const rsm::Geometry g = plane(48, 32);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::vector<glm::vec3> input(g.position.size());
  for (auto& v : input) v = {u(rng), u(rng), u(rng)};
  std::vector<glm::vec3> dir(input.size(), glm::vec3(0, 0, 1));
  rsm::FilterParams f;
  f.detail_clip = false;
  std::vector<glm::vec3> smooth = input, d = dir;
  rsm::atrous(g, f, smooth, d);
  f.detail_clip = true;
  f.gamma = 0;
  std::vector<glm::vec3> clipped = input;
  d = dir;
  rsm::atrous(g, f, clipped, d);
  f.gamma = 1e6f;
  std::vector<glm::vec3> kept = input;
  d = dir;
  rsm::atrous(g, f, kept, d);
  double smooth_spread = 0, input_spread = 0;
  for (size_t i = 0; i < input.size(); ++i) {
    ASSERT_NEAR(clipped[i].x, smooth[i].x, 1e-6) << i;
    ASSERT_NEAR(kept[i].x, input[i].x, 1e-4) << i;
    ASSERT_NEAR(kept[i].z, input[i].z, 1e-4) << i;
    smooth_spread += std::abs(smooth[i].x - 0.5);
    input_spread += std::abs(input[i].x - 0.5);
  }
  EXPECT_LT(smooth_spread, 0.5 * input_spread);  // the smoothing does smooth
}

// §7.1's edge stopping: across a depth edge of 1 m (100 times the depth tolerance) w_z vanishes,
// so an image of 0 on the near half and 1 on the far half comes out of four iterations unchanged
// on both sides, to 1e-3 next to the edge.
TEST(RsmPhotonsFilters, AtrousKeepsADepthEdge) {
  const rsm::Geometry g = plane(48, 16, 1.f);
  std::vector<glm::vec3> e(g.position.size()), dir(e.size(), glm::vec3(0, 0, 1));
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 48; ++x) e[size_t(y) * 48 + x] = glm::vec3(x >= 24 ? 1.f : 0.f);
  rsm::FilterParams f;
  rsm::atrous(g, f, e, dir);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 48; ++x)
      ASSERT_NEAR(e[size_t(y) * 48 + x].x, x >= 24 ? 1.f : 0.f, 1e-3) << x << "," << y;
}

// Eq. 7.10 (the prose's reading): the mean direction's cosine with the shading normal over the one
// with the geometric normal (plus epsilon, at most sl_max); off, E albedo / pi.
TEST(RsmPhotonsFilters, DirectionTermFollowsEquation710) {
  rsm::ShadeParams s;
  const glm::vec3 e{2, 2, 2}, albedo{0.5f, 0.5f, 0.5f}, w = glm::normalize(glm::vec3(0, 1, 1));
  const glm::vec3 flat{0, 1, 0}, tilted = glm::normalize(glm::vec3(0, 1, 0.5f));
  EXPECT_NEAR(rsm::shade(e, albedo, w, tilted, flat, s).x, 1 / rsm::kPi, 1e-6);
  s.direction_term = true;
  const float term = glm::dot(w, tilted) / (glm::dot(w, flat) + s.epsilon);
  EXPECT_NEAR(rsm::shade(e, albedo, w, tilted, flat, s).x, term / rsm::kPi, 1e-6);
  // Grazing mean direction: the 1 / cosine is clamped to sl_max.
  const glm::vec3 grazing = glm::normalize(glm::vec3(0, 0.01f, 1));
  const float clamped = std::max(0.f, glm::dot(grazing, tilted)) * s.sl_max;
  EXPECT_NEAR(rsm::shade(e, albedo, grazing, tilted, flat, s).x, clamped / rsm::kPi, 1e-5);
}

fs::path work_dir(const std::string& name) {
  return pb::testing::work_dir("rsm_photons_test", name);
}

// The descriptor's check and the schema's choices, through the plan `photonbench validate` makes:
// each bad parameter is bad input reported at the config's file, line and column with the key at
// fault.
TEST(RsmPhotons, RefusesBadParametersAtTheirKey) {
  fs::path dir = work_dir("check");
  const std::pair<const char*, const char*> cases[] = {
      {"rsm_resolution: 48", "rsm_resolution: 48 is not a power of two"},
      {"photon_near: 2, photon_far: 1", "photon_far: 1 is not beyond photon_near = 2"},
      {"kernel_min_radius: 0.2, kernel_max_radius: 0.1", "kernel_max_radius: 0.1 is below"},
      {"first_hit_roulette: true", "first_hit_roulette: true needs sampler: tracer"},
      // An enumeration's unknown name, with the closest of its choices.
      {"splat_scale: hlaf",
       "params.splat_scale: 'hlaf' is not one of: full, half, quarter; did you mean 'half'?"}};
  for (const auto& [params, message] : cases) {
    const std::string error = plan_error(dir, std::string("name: check\n"
                                                          "resolution: [64, 36]\n"
                                                          "scenes: [cornell-spot]\n"
                                                          "techniques:\n"
                                                          "  - technique: rsm-photons\n"
                                                          "    params: {") +
                                                  params + "}\n");
    EXPECT_NE(error.find("config.yaml:6:"), std::string::npos) << params << ": " << error;
    EXPECT_NE(error.find(message), std::string::npos) << error;
  }
}

constexpr uint32_t kReferenceSamples = 256;

double image_mean(const pb::io::Image& image) {
  double sum = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c) sum += image.at(x, y, c);
  return sum / (3.0 * image.pixel_count());
}

// The energy of the estimate: on cornell-spot at 128x72, the screen's one-bounce indirect light
// (the indirect class truncated at the technique's two surface interactions) against its
// reference, with every filter off and with all on, frame 8 after 8 frames of accumulation. Kernels
// conserve a photon's power on a flat receiver (E = Phi / A over the ellipse of area A), so what is
// lost is what the frustum cull drops at the screen's edges and what the ellipsoid test misses on
// curved or narrow receivers (the blocks' edges): the bound, 15%, is fixed in advance.
// Each region's ratio, bound 35%: 0.72 to 0.89 measured without filters, 0.88 to 0.97 with both
// (the blocks §6.2.1's rule leaves dark lie unevenly, most in the regions of the boxes' edges).
// Light moved 0.25 m along x, or mirrored across the box, puts regions at 0.02 to 0.59 and 1.25.
constexpr double kRegionBound = 0.35;
TEST(RsmPhotons, IndirectEnergyMatchesTheReference) {
  fs::path dir = work_dir("energy");
  const int width = 128, height = 72, frame = 8;
  const std::string config = fmt::format(
      "name: rsm-energy\n"
      "resolution: [{}, {}]\n"
      "seed: 1\n"
      "scenes: [cornell-spot]\n"
      "limits: {{cell_seconds: 300}}\n"
      "frames: {{warmup: {}, count: 1, metrics_every: 1}}\n"
      "metrics: [psnr]\n"
      "reference: {{samples: {}, max_bounces: 2, cache_dir: {}}}\n"
      "techniques:\n"
      "  - {{technique: rsm-photons, params: {{photons: 40000, temporal: false, spatial: "
      "false}}}}\n"
      "  - {{technique: rsm-photons, params: {{photons: 40000, temporal: true, spatial: true}}}}\n",
      width, height, frame, kReferenceSamples, (dir / "refs").string());
  ASSERT_EQ(run_config(dir, config), 0) << "see " << (dir / "log.txt");
  pb::scene::Scene scene = pb::scene::load_scene(PB_SOURCE_DIR "/scenes/cornell-spot.yaml");
  pb::trace::ReferenceCache cache(dir / "refs");
  pb::trace::ReferenceOptions options;
  options.samples = kReferenceSamples;
  options.max_bounces = 2;
  const pb::io::Image reference_image = cache.get_or_render(
      scene, scene.at(uint32_t(frame)), pb::trace::PathClass::indirect, width, height, options);
  const double reference = image_mean(reference_image);
  ASSERT_GT(reference, 0);
  // Energy where it belongs: the screen in 4 x 2 regions of 32 x 36 pixels, each region's indirect
  // light over the reference's there, for the regions holding at least a quarter of the screen's
  // mean (elsewhere the ratio of two small numbers says little).
  auto region_means = [&](const pb::io::Image& image) {
    std::vector<double> means(8, 0.0);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        for (int c = 0; c < 3; ++c) means[(y / 36) * 4 + x / 32] += image.at(x, y, c);
    for (double& m : means) m /= 3.0 * 32 * 36;
    return means;
  };
  const std::vector<double> reference_regions = region_means(reference_image);
  for (const char* filters : {"false", "true"}) {
    fs::path cell = find_cell(dir, "rsm-photons", {{"temporal", filters}, {"spatial", filters}});
    ASSERT_FALSE(cell.empty()) << filters;
    auto record = read_json(cell / "cell.json");
    EXPECT_EQ(record["status"], "ok") << record.dump();
    EXPECT_EQ(record["validation"], validation_on());
    const pb::io::Image image = frame_image(cell, frame, "indirect");
    ASSERT_TRUE(all_finite(image));
    const double ratio = image_mean(image) / reference;
    std::printf("filters %s: screen indirect / reference = %.4f\n", filters, ratio);
    EXPECT_NEAR(ratio, 1.0, 0.15) << "filters " << filters;
    const std::vector<double> regions = region_means(image);
    int compared = 0;
    for (int r = 0; r < 8; ++r) {
      if (reference_regions[r] < 0.25 * reference) continue;
      ++compared;
      const double region_ratio = regions[r] / reference_regions[r];
      std::printf("  region %d (reference %.4f): %.3f\n", r, reference_regions[r], region_ratio);
      EXPECT_NEAR(region_ratio, 1.0, kRegionBound) << "filters " << filters << ", region " << r;
    }
    EXPECT_GE(compared, 4);
    const auto sums = counters(cell);
    EXPECT_GT(sums["splats"], 1000);
    EXPECT_GT(sums["rsm_texels_active"], 0);
  }
}

// Gathering (§6.3) against splatting (§6.2) where they must agree: the same photons (one seed, one
// frame, so the same kernels), no filters, the same targets and the same ellipsoid test of the same
// receiver points: the splat sums what the rasteriser lets through the proxies, the gather what its
// tile lists hold, and the tile cull is conservative, so the two indirect images differ only where
// rounding moves a receiver point across a kernel's boundary (the splat's ray comes from the
// proxy's interpolated position, the gather's from the inverse view-projection): there a pixel
// gains or loses that kernel. On cornell-spot at 128x72, 20,000 photons: 32 of 9,216 pixels
// differ after the upsampling (2 splat pixels), the mean absolute difference is 1.2e-2 of the
// mean (1.1e-3 when each pixel tested one point: with §6.2.1's two, a point where the ray meets
// a tangent plane at a grazing angle moves further with the ray's rounding, and the kernels there
// are small and bright); the bounds, at most 1% of the pixels and 2e-2 of the mean. A third cell's
// index buffer holds 5% of a kernel's entries (gather_capacity 0.05): entries are dropped, counted
// and warned about, and the image loses light (the thesis's "clearly visible corruption").
TEST(RsmPhotons, GatheringAgreesWithSplatting) {
  fs::path dir = work_dir("gather");
  const std::string config = fmt::format(
      "name: rsm-gather\n"
      "resolution: [128, 72]\n"
      "seed: 1\n"
      "scenes: [cornell-spot]\n"
      "limits: {{cell_seconds: 300}}\n"
      "frames: {{warmup: 0, count: 1, metrics_every: 1}}\n"
      "metrics: [psnr]\n"
      "reference: {{samples: 2, max_bounces: 2, cache_dir: {}}}\n"
      "techniques:\n"
      "  - technique: rsm-photons\n"
      "    params: {{photons: 20000, temporal: false, spatial: false, estimate: [splat, gather]}}\n"
      "  - technique: rsm-photons\n"
      "    params: {{photons: 20000, temporal: false, spatial: false, estimate: gather, "
      "gather_capacity: 0.05}}\n",
      (dir / "refs").string());
  ASSERT_EQ(run_config(dir, config), 0) << "see " << (dir / "log.txt");
  const fs::path splat = find_cell(dir, "rsm-photons", {{"estimate", "splat"}});
  const fs::path short_list = find_cell(dir, "rsm-photons", {{"gather_capacity", "0.05"}});
  fs::path gather;
  for (const auto& entry : fs::directory_iterator(dir / "run" / "cells"))
    if (read_json(entry.path() / "cell.json")["params"].value("estimate", "") == "gather" &&
        entry.path() != short_list)
      gather = entry.path();
  ASSERT_FALSE(splat.empty() || gather.empty() || short_list.empty());
  for (const fs::path& cell : {splat, gather, short_list})
    EXPECT_EQ(read_json(cell / "cell.json")["status"], "ok") << cell;
  const pb::io::Image a = frame_image(splat, 0, "indirect"), b = frame_image(gather, 0, "indirect");
  ASSERT_EQ(a.pixel_count(), b.pixel_count());
  const double mean = image_mean(a);
  ASSERT_GT(mean, 0);
  double difference = 0;
  int differing = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      double pixel = 0;
      for (int c = 0; c < 3; ++c) pixel += std::abs(double(a.at(x, y, c)) - b.at(x, y, c));
      difference += pixel / 3;
      differing += pixel > 1e-5 * mean;
    }
  difference /= double(a.pixel_count());
  std::printf("gather - splat: %d of %zu pixels differ, mean |difference| %.3g of the mean\n",
              differing, size_t(a.pixel_count()), difference / mean);
  EXPECT_LT(differing, a.pixel_count() / 100);
  EXPECT_LT(difference, 2e-2 * mean);
  auto sums = counters(gather), short_sums = counters(short_list);
  EXPECT_GT(sums["gather_entries"], sums["splats"]);  // each kernel in at least one tile's list
  EXPECT_EQ(sums["gather_dropped"], 0);
  EXPECT_GT(short_sums["gather_dropped"], 0);
  EXPECT_NE(warnings(short_list).find("raise gather_capacity"), std::string::npos);
  EXPECT_LT(image_mean(frame_image(short_list, 0, "indirect")), 0.9 * mean);
}

// §6.2.1's rule at a depth edge. A panel 1.5 m in front of a wall, its right edge slanted (so that
// the edge crosses the half-resolution blocks at every offset), a point light between the two:
// the panel's front, which the camera sees, receives no light at all (nothing lies in front of
// it), while the wall beside it is lit indirectly by the panel's back. Every bit of indirect light
// on the panel's pixels next to the edge is light of the wall spread across the edge. Measured on
// the raw half-resolution estimate (no filters): the panel's band (pixels within 2 of a wall pixel)
// over the wall's light 3 to 6 pixels from the panel. The upsampling is bilinear (the thesis's),
// so where the edge falls on a block boundary a panel pixel still takes a quarter of the wall
// block beside it; where a block straddles the edge it takes nothing (the block is rejected). Half
// the edge's rows do each: about 1/8 of the wall's light on the pixel next to the edge, 1/16 over
// the 2-pixel band (0.040 measured, splat and gather alike). Testing one G-buffer pixel of each
// block (the splat before §6.2.1's rule), a straddling block whose tested pixel is the wall's
// spreads the wall's light over the block's panel pixels too: 0.246 measured. Bound: 0.15.
TEST(RsmPhotons, HalfResolutionKeepsLightOnItsSideOfADepthEdge) {
  fs::path dir = work_dir("depth_edge");
  const int width = 128, height = 72;
  const fs::path scene_file = dir / "panel.yaml";
  std::ofstream(scene_file) << R"(purpose: a lit wall behind an unlit panel (rsm-photons test)
fps: 30
frames: 2
camera: {position: [0, 0, 3], target: [0, 0, 0], fov_deg: 40}
lights:
  - {name: bulb, type: point, position: [-0.5, 0, 0.25], color: [1, 1, 1], intensity: 4}
materials:
  white: {type: diffuse, albedo: 0.8}
objects:
  - {name: wall, shape: {type: quad, size: [6, 6]}, material: white,
     transform: {translate: [0, 0, -1], rotate_deg: [90, 0, 0]}}
  - {name: panel, shape: {type: box, size: [2, 3, 0.02]}, material: white,
     transform: {translate: [-0.9, 0, 0.5], rotate_deg: [0, 0, 7]}}
)";
  const std::string config = fmt::format(
      "name: rsm-depth-edge\n"
      "resolution: [{}, {}]\n"
      "seed: 1\n"
      "scenes: [{}]\n"
      "limits: {{cell_seconds: 300}}\n"
      "frames: {{warmup: 0, count: 1, metrics_every: 1}}\n"
      "metrics: [psnr]\n"
      "reference: {{samples: 2, max_bounces: 2, cache_dir: {}}}\n"
      "techniques:\n"
      "  - technique: rsm-photons\n"
      "    params: {{photons: 40000, temporal: false, spatial: false, estimate: [splat, "
      "gather]}}\n",
      width, height, scene_file.string(), (dir / "refs").string());
  ASSERT_EQ(run_config(dir, config), 0) << "see " << (dir / "log.txt");
  // Which pixels are the panel's: no direct light reaches its front (the light is behind it).
  pb::scene::Scene scene = pb::scene::load_scene(scene_file);
  pb::trace::ReferenceCache cache(dir / "refs");
  pb::trace::ReferenceOptions options;
  options.samples = 4;
  const pb::io::Image direct = cache.get_or_render(
      scene, scene.at(0u), pb::trace::PathClass::direct, width, height, options);
  auto brightness = [](const pb::io::Image& image, int x, int y) {
    return (double(image.at(x, y, 0)) + image.at(x, y, 1) + image.at(x, y, 2)) / 3;
  };
  std::vector<int> panel(size_t(width) * height);
  int panel_pixels = 0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const bool unlit = brightness(direct, x, y) < 1e-6;
      panel[size_t(y) * width + x] = unlit;
      panel_pixels += unlit;
    }
  ASSERT_GT(panel_pixels, width * height / 4);
  ASSERT_LT(panel_pixels, width * height * 3 / 4);
  // Each pixel's distance (Chebyshev, up to 7) to the nearest pixel of the other kind.
  auto distance_to_other = [&](int x, int y) {
    const int mine = panel[size_t(y) * width + x];
    for (int r = 1; r <= 6; ++r)
      for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx) {
          const int qx = x + dx, qy = y + dy;
          if (qx < 0 || qy < 0 || qx >= width || qy >= height) continue;
          if (panel[size_t(qy) * width + qx] != mine) return r;
        }
    return 7;
  };
  for (const char* estimate : {"splat", "gather"}) {
    const fs::path cell = find_cell(dir, "rsm-photons", {{"estimate", estimate}});
    ASSERT_FALSE(cell.empty()) << estimate;
    EXPECT_EQ(read_json(cell / "cell.json")["status"], "ok") << estimate;
    const pb::io::Image indirect = frame_image(cell, 0, "indirect");
    double band = 0, wall = 0;
    int band_pixels = 0, wall_pixels = 0;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const int d = distance_to_other(x, y);
        if (panel[size_t(y) * width + x] && d <= 2) {
          band += brightness(indirect, x, y), ++band_pixels;
        } else if (!panel[size_t(y) * width + x] && d >= 3 && d <= 6) {
          wall += brightness(indirect, x, y), ++wall_pixels;
        }
      }
    ASSERT_GT(band_pixels, 2 * height);
    ASSERT_GT(wall_pixels, 4 * height);
    ASSERT_GT(wall, 0) << estimate;
    const double bleed = (band / band_pixels) / (wall / wall_pixels);
    std::printf("%s: the panel's edge band holds %.3f of the wall's light beside it\n", estimate,
                bleed);
    EXPECT_LT(bleed, 0.15) << estimate;
  }
}

// The wavelet sampler's budget (§5.3): 16 times the photons must mean 16 times the independent
// samples, bounces included. A narrow spot lights a spot of floor about 7 cm across in a closed
// grey box, so where a photon's second hit lands (all the indirect light seen: walls and ceiling)
// is decided by its bounce direction, hardly by its start point. Kernels of one fixed radius
// (kernel_min_radius = kernel_max_radius; Eq. 6.2's density radius would shrink them as photons
// grow and keep each pixel's kernel count, and so its noise, about constant), no filters: the
// frame-to-frame difference of the indirect image (each frame draws fresh samples) falls as
// 1 / sqrt(photons) for independent photons, to 1/4 at 16 times the photons (0.249 measured).
// With every round re-using the bounce samples of one round's paths (a path's own sample index in
// every round), the 16 rounds bounce in the same 4,096 directions and the difference hardly falls
// (0.894 measured). Bound: 0.45.
TEST(RsmPhotons, WaveletRoundsDrawIndependentBounces) {
  fs::path dir = work_dir("wavelet_budget");
  const fs::path scene_file = dir / "narrow-spot.yaml";
  std::ofstream(scene_file) << R"(purpose: a narrow spot in a grey box (rsm-photons test)
fps: 30
frames: 2
camera: {position: [0.5, 0.5, 2.44], target: [0.5, 0.5, 0], fov_deg: 39.3}
lights:
  - {name: spot, type: spot, position: [0.5, 0.95, 0.5], target: [0.5, 0, 0.5], intensity: 40,
     color: [1, 1, 1], inner_deg: 1.5, outer_deg: 2}
materials:
  grey: {type: diffuse, albedo: 0.7}
objects:
  - {name: floor, shape: {type: quad}, material: grey, transform: {translate: [0.5, 0, 0.5]}}
  - {name: ceiling, shape: {type: quad}, material: grey,
     transform: {translate: [0.5, 1, 0.5], rotate_deg: [180, 0, 0]}}
  - {name: back, shape: {type: quad}, material: grey,
     transform: {translate: [0.5, 0.5, 0], rotate_deg: [90, 0, 0]}}
  - {name: left, shape: {type: quad}, material: grey,
     transform: {translate: [0, 0.5, 0.5], rotate_deg: [0, 0, -90]}}
  - {name: right, shape: {type: quad}, material: grey,
     transform: {translate: [1, 0.5, 0.5], rotate_deg: [0, 0, 90]}}
)";
  const std::string config = fmt::format(
      "name: rsm-wavelet-budget\n"
      "resolution: [128, 72]\n"
      "seed: 1\n"
      "scenes: [{}]\n"
      "limits: {{cell_seconds: 300}}\n"
      "frames: {{warmup: 0, count: 2, metrics_every: 1}}\n"
      "metrics: [psnr]\n"
      "reference: {{samples: 2, max_bounces: 2, cache_dir: {}}}\n"
      "techniques:\n"
      "  - technique: rsm-photons\n"
      "    params: {{photons: [4096, 65536], sampler: wavelet, temporal: false, spatial: false,\n"
      "             kernel_min_radius: 0.04, kernel_max_radius: 0.04}}\n",
      scene_file.string(), (dir / "refs").string());
  ASSERT_EQ(run_config(dir, config), 0) << "see " << (dir / "log.txt");
  auto frame_difference = [&](const std::string& photons) {
    const fs::path cell = find_cell(dir, "rsm-photons", {{"photons", photons}});
    EXPECT_FALSE(cell.empty()) << photons;
    if (cell.empty()) return 0.0;
    EXPECT_EQ(read_json(cell / "cell.json")["status"], "ok") << photons;
    const pb::io::Image a = frame_image(cell, 0, "indirect"), b = frame_image(cell, 1, "indirect");
    double squares = 0, sum = 0;
    for (int y = 0; y < a.height; ++y)
      for (int x = 0; x < a.width; ++x)
        for (int c = 0; c < 3; ++c) {
          const double d = double(a.at(x, y, c)) - b.at(x, y, c);
          squares += d * d;
          sum += 0.5 * (double(a.at(x, y, c)) + b.at(x, y, c));
        }
    const double n = 3.0 * a.pixel_count();
    EXPECT_GT(sum, 0) << photons;
    return sum > 0 ? std::sqrt(squares / n) / (sum / n) : 0.0;
  };
  const double few = frame_difference("4096"), many = frame_difference("65536");
  ASSERT_GT(few, 0);
  std::printf(
      "frame-to-frame RMS difference over the mean: %.4f at 4,096 photons, %.4f at 65,536 "
      "(ratio %.3f)\n",
      few, many, many / few);
  EXPECT_LT(many / few, 0.45);
}

}  // namespace rsm_photons_test
