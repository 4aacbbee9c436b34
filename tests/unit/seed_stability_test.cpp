// Temporal and seed stability: the flicker metric (metrics/flicker.h) on synthetic frame sequences
// with known answers, and the seed axis of a plan (plan/plan.h, `seeds: K`).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>

#include "metrics/flicker.h"
#include "metrics/z_test.h"
#include "photonbench/error.h"
#include "plan/plan.h"
#include "plan_scratch.h"

namespace pb {
namespace seed_stability_test {

namespace fs = std::filesystem;

// A smooth, non-constant linear image: value(x, y, c) * scale.
io::Image ramp(float scale) {
  io::Image image(24, 16, 3);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c)
        image.at(x, y, c) = scale * (0.1f + 0.03f * x + 0.02f * y + 0.1f * c);
  return image;
}

io::Image filled(const io::Image& like, float value) {
  io::Image image(like.width, like.height, like.channels);
  std::fill(image.pixels.begin(), image.pixels.end(), value);
  return image;
}

// One reference frame: its mean, and halves mean +- noise (noise 0: a noiseless reference).
struct Frame {
  io::Image mean, variance, half_a, half_b;
  explicit Frame(io::Image m, float noise = 0)
      : mean(std::move(m)), variance(filled(mean, noise * noise)), half_a(mean), half_b(mean) {
    for (size_t i = 0; i < mean.pixels.size(); ++i) {
      half_a.pixels[i] += noise;
      half_b.pixels[i] -= noise;
    }
  }
  metrics::NoisyReference noisy() const { return {mean, variance, half_a, half_b}; }
};

TEST(Flicker, StaticExactSequenceIsZero) {
  const Frame r(ramp(1));
  EXPECT_EQ(metrics::flicker(r.noisy(), r.noisy(), r.mean, r.mean).value, 0.0);
  // A moving scene followed exactly, and an error that stays in place, flicker no more.
  const Frame a(ramp(1)), b(ramp(2));
  EXPECT_NEAR(metrics::flicker(a.noisy(), b.noisy(), a.mean, b.mean).value, 0.0, 1e-12);
  io::Image biased_a = a.mean, biased_b = b.mean;
  for (size_t i = 0; i < biased_a.pixels.size(); ++i) {
    const float bias = 0.05f * float(i % 7);
    biased_a.pixels[i] += bias;
    biased_b.pixels[i] += bias;
  }
  EXPECT_NEAR(metrics::flicker(a.noisy(), b.noisy(), biased_a, biased_b).value, 0.0, 1e-6);
}

TEST(Flicker, AlternatingSequenceScoresTwiceItsAmplitude) {
  // T alternates between R (1 + a) and R (1 - a) over a static R: the frame difference is 2a R
  // against the reference's 0, so flicker = RMS(2a R) / RMS(R) = 2a.
  const Frame r(ramp(1));
  for (double a : {0.01, 0.1, 0.3}) {
    io::Image up = r.mean, down = r.mean;
    for (size_t i = 0; i < up.pixels.size(); ++i) {
      up.pixels[i] *= float(1 + a);
      down.pixels[i] *= float(1 - a);
    }
    // Float pixels: the difference of two rounded values is exact to about 1e-7 of the level.
    EXPECT_NEAR(metrics::flicker(r.noisy(), r.noisy(), up, down).value, 2 * a, 1e-6) << a;
    EXPECT_NEAR(metrics::flicker(r.noisy(), r.noisy(), down, up).value, 2 * a, 1e-6) << a;
  }
}

TEST(Flicker, FloorIsTheDifferenceOfTheReferencesNoiseRelativeToTheirLevel) {
  // Level L; noise samples (H1 - H2) / 2 of +n in one frame and -n in the other: the difference
  // of the references' noises is 2n everywhere, so floor = 2n / L.
  const io::Image level = filled(ramp(1), 0.5f);
  const Frame p(level, 0.02f), c(level, -0.02f);
  const metrics::Flicker f = metrics::flicker(p.noisy(), c.noisy(), level, level);
  EXPECT_NEAR(f.floor, 2 * 0.02 / 0.5, 1e-6);
  EXPECT_EQ(f.value, 0.0);
  // The same noise in both frames (one sample sequence for both references) cancels in R_c - R_p:
  // no floor, though each reference alone is as noisy.
  const Frame same(level, 0.02f);
  EXPECT_NEAR(metrics::flicker(same.noisy(), same.noisy(), level, level).floor, 0.0, 1e-9);
}

TEST(Flicker, RejectsMismatchedAndBlackFrames) {
  const Frame r(ramp(1));
  io::Image small(8, 8, 3);
  EXPECT_THROW(metrics::flicker(r.noisy(), r.noisy(), r.mean, small), InputError);
  const Frame black(filled(r.mean, 0));
  EXPECT_THROW(metrics::flicker(black.noisy(), black.noisy(), r.mean, r.mean), InputError);
}

// Two independent estimates of one image: N(truth + shift, variance) per pixel-channel, with that
// variance stored beside each.
struct Estimates {
  io::Image a, var_a, b, var_b;
};

Estimates draw(std::mt19937& rng, double shift_sigmas, int shifted_pixels) {
  const io::Image truth = ramp(1);
  Estimates e{truth, filled(truth, 0), truth, filled(truth, 0)};
  std::normal_distribution<double> normal;
  for (size_t i = 0; i < truth.pixels.size(); ++i) {
    const double var_a = 1e-4 * (1 + i % 5), var_b = 4e-4;
    e.var_a.pixels[i] = float(var_a);
    e.var_b.pixels[i] = float(var_b);
    const double shift = int(i / 3) < shifted_pixels ? shift_sigmas * std::sqrt(var_a + var_b) : 0;
    e.a.pixels[i] = float(truth.pixels[i] + shift + std::sqrt(var_a) * normal(rng));
    e.b.pixels[i] = float(truth.pixels[i] + std::sqrt(var_b) * normal(rng));
  }
  return e;
}

TEST(ZTest, EqualImagesAreRejectedAtTheStatedRate) {
  // 600 pairs of equal distributions at alpha = 0.05: about 30 rejections (binomial sd 5.3); the
  // image p-value is below alpha exactly when the test rejects.
  std::mt19937 rng(12345);
  int rejected = 0;
  for (int trial = 0; trial < 600; ++trial) {
    const Estimates e = draw(rng, 0, 0);
    const metrics::ZTestResult z = metrics::z_test(e.a, e.var_a, e.b, e.var_b, 0.05);
    EXPECT_EQ(z.tested, size_t(24 * 16 * 3));
    EXPECT_EQ(z.equal(), z.rejected == 0) << trial;
    rejected += !z.equal();
  }
  EXPECT_GE(rejected, 14);
  EXPECT_LE(rejected, 46);
}

TEST(ZTest, AShiftedRegionIsRejected) {
  std::mt19937 rng(777);
  for (int trial = 0; trial < 50; ++trial) {
    // 8 pixels off by 7 standard deviations of their difference, in 384.
    const Estimates e = draw(rng, 7, 8);
    const metrics::ZTestResult z = metrics::z_test(e.a, e.var_a, e.b, e.var_b, 0.05);
    EXPECT_FALSE(z.equal()) << trial;
    EXPECT_LT(z.p_value, 1e-3) << trial;
    EXPECT_GE(z.rejected, 1u);
  }
}

TEST(ZTest, ExactPixelsPassWhenEqualAndRejectWhenNot) {
  const io::Image image = ramp(1), zero = filled(image, 0);
  const metrics::ZTestResult same = metrics::z_test(image, zero, image, zero);
  EXPECT_EQ(same.exact, same.tested);
  EXPECT_EQ(same.exact_mismatches, 0u);
  EXPECT_EQ(same.p_value, 1.0);
  io::Image other = image;
  other.pixels[5] += 0.001f;
  const metrics::ZTestResult differs = metrics::z_test(image, zero, other, zero);
  EXPECT_EQ(differs.rejected, 1u);
  EXPECT_EQ(differs.exact_mismatches, 1u);
  EXPECT_EQ(differs.rejected_share_with_variance(), 0.0);  // no pixel-channel has a variance
  EXPECT_EQ(differs.p_value, 0.0);
  EXPECT_THROW(metrics::z_test(image, zero, image, zero, 1.5), InputError);
  EXPECT_THROW(metrics::z_test(image, filled(image, -1), image, zero), InputError);
}

// A config in a scratch folder, with the build's plugins.
struct Scratch : testing::PlanScratch {
  Scratch() : PlanScratch("seed_test") {}
};

const char* kSweep = R"(name: t
resolution: [64, 36]
frames: {warmup: 0, count: 2, metrics_every: 1}
seed: 7
scenes: [cornell-box]
techniques:
  - technique: direct
    params: {shadow_map_size: [64, 128]}
)";

TEST(SeedAxis, EachCellRunsWithKConsecutiveSeeds) {
  const Scratch scratch;
  const run::RunPlan plain = scratch.plan(kSweep);
  ASSERT_EQ(plain.cells.size(), 2u);
  for (const run::Cell& cell : plain.cells) {
    EXPECT_EQ(cell.seed, 7u);
    EXPECT_EQ(cell.seed_index, 0u);
  }
  const run::RunPlan seeded = scratch.plan(kSweep, {"seeds=3"});
  ASSERT_EQ(seeded.cells.size(), 6u);
  std::set<std::string> ids;
  for (size_t i = 0; i < seeded.cells.size(); ++i) {
    const run::Cell& cell = seeded.cells[i];
    const run::Cell& base = plain.cells[i / 3];
    EXPECT_EQ(cell.seed_index, i % 3);
    EXPECT_EQ(cell.seed, 7u + i % 3);
    // The parameters are the plain cell's; the id is its id with the seed after it.
    EXPECT_EQ(cell.params, base.params);
    EXPECT_EQ(cell.id, base.id + "__seed" + std::to_string(7 + i % 3));
    EXPECT_EQ(cell.seed_group, base.id);
    ids.insert(cell.id);
  }
  EXPECT_EQ(ids.size(), 6u);
  EXPECT_EQ(seeded.cell(seeded.cells[4].id).seed, seeded.cells[4].seed);
}

// seed_order: rounds: the same cells, seed index i of every cell in round i, forward then backward
// (A B C, C B A, A B C), so that a drift of the machine's load weighs on every cell alike.
TEST(SeedAxis, RoundsRunEverySeedOverAllCellsAlternatingDirection) {
  const Scratch scratch;
  const std::string three = "techniques.0.params.shadow_map_size=[64,128,256]";
  const run::RunPlan plain = scratch.plan(kSweep, {three});
  ASSERT_EQ(plain.cells.size(), 3u);
  const run::RunPlan rounds = scratch.plan(kSweep, {three, "seeds=3", "seed_order=rounds"});
  ASSERT_EQ(rounds.cells.size(), 9u);
  const size_t expected_base[9] = {0, 1, 2, 2, 1, 0, 0, 1, 2};
  for (size_t i = 0; i < rounds.cells.size(); ++i) {
    const run::Cell& cell = rounds.cells[i];
    const run::Cell& base = plain.cells[expected_base[i]];
    EXPECT_EQ(cell.seed_index, i / 3) << i;
    EXPECT_EQ(cell.seed, 7u + i / 3) << i;
    EXPECT_EQ(cell.params, base.params) << i;
    EXPECT_EQ(cell.id, base.id + "__seed" + std::to_string(7 + i / 3)) << i;
    EXPECT_EQ(cell.seed_group, base.id) << i;
  }
  // grouped (the default) keeps each cell's seeds together; an unknown order is refused at its key.
  EXPECT_EQ(scratch.plan(kSweep, {three, "seeds=3", "seed_order=grouped"}).cells[1].seed_index, 1u);
  try {
    scratch.plan(kSweep, {three, "seeds=3", "seed_order=shuffled"});
    ADD_FAILURE() << "seed_order=shuffled was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("seed_order"), std::string::npos) << e.what();
  }
}

TEST(SeedAxis, BadSeedCountsAreInputErrors) {
  const Scratch scratch;
  for (const char* bad : {"seeds=0", "seeds=-2", "seeds=1001", "seeds=two"}) {
    try {
      scratch.plan(kSweep, {bad});
      ADD_FAILURE() << bad << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("seeds"), std::string::npos) << e.what();
    }
  }
  // 11 cells x 1000 seeds: more cells than a run may have (11 x 909 is not).
  const std::string eleven =
      "techniques.0.params.shadow_map_size=[16,17,18,19,20,21,22,23,24,25,26]";
  EXPECT_EQ(scratch.plan(kSweep, {"seeds=909", eleven}).cells.size(), 9999u);
  try {
    scratch.plan(kSweep, {"seeds=1000", eleven});
    ADD_FAILURE() << "11000 cells were accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("seeds: 1000 x 11 cells"), std::string::npos) << e.what();
  }
}

}  // namespace seed_stability_test
}  // namespace pb
