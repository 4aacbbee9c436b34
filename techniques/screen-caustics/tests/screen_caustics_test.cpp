// screen-caustics technique: Eq. 12.1's weights (sc_filter.h, the text the shaders run) and one
// filtered photon integrating to its flux under the physical pixel-area term, the 8-bit count's
// saturation at 255, the Halton emission's round robin, aim and scramble, and bad parameters
// refused with their key.
#include "screen_caustics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "plan_scratch.h"

namespace screen_caustics_test {

// The filter pass's sum at pixel (x, y) of a count buffer (sc_filter.comp's loop, on the CPU).
float weighted_counts(const std::vector<uint32_t>& counts, int width, int height, int x, int y,
                      int k, uint32_t precision) {
  float sum = 0;
  for (int j = -k; j <= k; ++j)
    for (int i = -k; i <= k; ++i) {
      const int qx = x + i, qy = y + j;
      if (qx < 0 || qy < 0 || qx >= width || qy >= height) continue;
      sum += sc::sc_weight(i, j, k) * sc::sc_count(counts[size_t(qy) * width + qx], precision);
    }
  return sum;
}

// The flux a filtered count buffer gives back: irradiance times the surface's true footprint
// 4 d^2 tan tan / cos, summed over every pixel of a plane at view depth `depth` tilted to `cos`.
double integrated_flux(const std::vector<uint32_t>& counts, int width, int height, int k,
                       uint32_t precision, uint32_t scaling, float flux, float depth, float cos) {
  const float tx = std::tan(0.5f) / float(width), ty = std::tan(0.5f) / float(height);
  const float footprint = 4.f * tx * ty * depth * depth / cos;
  double total = 0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float w = weighted_counts(counts, width, height, x, y, k, precision);
      const float area = sc::sc_pixel_area(scaling, depth, cos, tx, ty);
      total += double(sc::sc_irradiance(w, sc::sc_weight_sum(k), flux, area)) * footprint;
    }
  return total;
}

TEST(ScreenCaustics, FilterWeightsSumAsTheThesisGives) {
  EXPECT_NEAR(sc::sc_weight_sum(3), 156.76, 0.005);
  EXPECT_FLOAT_EQ(sc::sc_weight(0, 0, 3), std::sqrt(19.f));
  EXPECT_FLOAT_EQ(sc::sc_weight(3, 3, 3), 1.f);
}

TEST(ScreenCaustics, OneFilteredPhotonIntegratesToItsFlux) {
  const int width = 32, height = 24;
  std::vector<uint32_t> counts(size_t(width) * height, 0);
  counts[size_t(11) * width + 13] = 1;
  const float flux = 0.25f;
  for (float cos : {1.f, 0.5f, 0.2f})
    for (float depth : {0.5f, 3.f})
      for (int k : {1, 3, 5}) {
        const double got = integrated_flux(counts, width, height, k, SC_PRECISION_FLOAT,
                                           SC_AREA_DIVIDE, flux, depth, cos);
        EXPECT_NEAR(got, flux, 1e-5) << "cos " << cos << " depth " << depth << " k " << k;
      }
  // The area term as printed (the cosine multiplies) brightens a tilted surface by 1 / cos^2.
  const double printed = integrated_flux(counts, width, height, 3, SC_PRECISION_FLOAT,
                                         SC_AREA_MULTIPLY, flux, 2.f, 0.5f);
  EXPECT_NEAR(printed, flux * 4.0, 1e-5);
}

TEST(ScreenCaustics, EightBitCountsSaturateAt255) {
  EXPECT_EQ(sc::sc_count(300, SC_PRECISION_8BIT), 255.f);
  EXPECT_EQ(sc::sc_count(255, SC_PRECISION_8BIT), 255.f);
  EXPECT_EQ(sc::sc_count(300, SC_PRECISION_FLOAT), 300.f);
  const int width = 16, height = 16;
  std::vector<uint32_t> counts(size_t(width) * height, 0);
  counts[size_t(8) * width + 8] = 300;
  EXPECT_NEAR(
      integrated_flux(counts, width, height, 3, SC_PRECISION_8BIT, SC_AREA_DIVIDE, 1.f, 1.f, 1.f),
      255.0, 1e-2);
  EXPECT_NEAR(
      integrated_flux(counts, width, height, 3, SC_PRECISION_FLOAT, SC_AREA_DIVIDE, 1.f, 1.f, 1.f),
      300.0, 1e-2);
}

// Values outside a parameter's range or enumeration are refused before any work, at the config's
// file, line and key; fewer photons than re-trace frames is allowed (some frames re-trace none).
TEST(ScreenCaustics, BadParametersAreRefusedWithTheirKey) {
  pb::testing::PlanScratch scratch("screen_caustics_test_params");
  auto error = [&](const std::string& params) {
    return scratch.refusal(
        "name: t\nscenes: [cornell-glass]\ntechniques:\n  - technique: screen-caustics\n"
        "    params: " +
        params + "\n");
  };
  std::string e = error("{count_precision: 16bit}");
  EXPECT_NE(e.find("config.yaml:5:"), std::string::npos) << e;
  EXPECT_NE(e.find("techniques[0].params.count_precision"), std::string::npos) << e;
  EXPECT_NE(e.find("8bit, float"), std::string::npos) << e;
  e = error("{area_scaling: divided}");
  EXPECT_NE(e.find("techniques[0].params.area_scaling"), std::string::npos) << e;
  EXPECT_NE(e.find("none, multiply, divide"), std::string::npos) << e;
  EXPECT_NE(error("{filter_k: 16}").find("techniques[0].params.filter_k"), std::string::npos);
  EXPECT_NE(error("{photons: 0}").find("techniques[0].params.photons"), std::string::npos);
  EXPECT_NE(error("{grid: 0}").find("techniques[0].params.grid"), std::string::npos);
  EXPECT_EQ(error("{photons: 1, retrace_frames: 8}"), "");
}

// Every Halton photon is listed by exactly one slice, and each starts on a texel the aim keeps,
// with the density that keeps its expected power.
TEST(ScreenCaustics, HaltonSlicesCoverEveryPhotonOnceInsideTheAim) {
  pb::trace::EmissionDensity aim;
  aim.width = aim.height = 4;
  aim.texels.assign(16, 0.f);
  aim.texels[5] = aim.texels[6] = 1.f;  // 2 of 16 texels
  sc::HaltonEmission emission;
  emission.configure({aim}, 1001, 8);
  pb::trace::EmitterInfo light{pb::trace::EmitterKind::point, glm::vec3(1.f)};
  pb::trace::EmissionFrame frame;
  frame.emitters = std::span<const pb::trace::EmitterInfo>(&light, 1);
  std::set<uint32_t> seen;
  for (uint32_t s = 0; s < 8; ++s) {
    emission.select_slice(s);
    const uint64_t n = emission.prepare(frame);
    for (uint64_t i = 0; i < n; ++i) {
      const pb::trace::EmissionPoint e = emission.emission(i);
      EXPECT_TRUE(seen.insert(e.id).second) << e.id;
      const int tx = int(e.uv.x * 4), ty = int(e.uv.y * 4);
      EXPECT_GT(aim.texels[size_t(ty) * 4 + tx], 0.f) << e.uv.x << " " << e.uv.y;
      EXPECT_FLOAT_EQ(e.photon_density, 1001.f * 8.f);  // N / (2 / 16 of the domain)
    }
  }
  EXPECT_EQ(seen.size(), 1001u);
}

// A seed axis's scramble moves the photons further along the Halton sequence: other points, each
// still listed once by its slice.
TEST(ScreenCaustics, SeedScrambleGivesOtherHaltonPoints) {
  sc::HaltonEmission emission;
  emission.configure({std::nullopt}, 64, 8);  // an area light: uniform emission
  pb::trace::EmitterInfo light{pb::trace::EmitterKind::quad, glm::vec3(1.f)};
  pb::trace::EmissionFrame frame;
  frame.emitters = std::span<const pb::trace::EmitterInfo>(&light, 1);
  emission.select_slice(3);
  ASSERT_EQ(emission.prepare(frame), 8u);
  const glm::vec2 plain = emission.emission(0).uv;
  frame.seed_scramble = 1;
  ASSERT_EQ(emission.prepare(frame), 8u);
  const pb::trace::EmissionPoint scrambled = emission.emission(0);
  EXPECT_NE(scrambled.uv, plain);
  EXPECT_EQ(scrambled.id, 3u);
  frame.seed_scramble = 2;
  emission.prepare(frame);
  EXPECT_NE(emission.emission(0).uv, scrambled.uv);
}

}  // namespace screen_caustics_test
