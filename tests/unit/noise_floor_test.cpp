// Noise floors (metrics/noise_floor.h) on synthetic references whose true image is known: a floor
// must predict the score of the true image against the noisy mean, E m(R, T), for each metric, with
// the kinds of noise a renderer makes (white Gaussian, rare bright samples, spatially correlated).
#include "metrics/noise_floor.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <vector>

#include "io/image.h"
#include "photonbench/error.h"

namespace pb::metrics {
namespace noise_floor_test {

constexpr int kWidth = 192, kHeight = 128, kSamples = 32;

// A linear-radiance scene: a gradient wall, a dark corner, a bright patch (above 1, so the display
// encoding clamps it), sharp edges and a soft gradient in colour.
io::Image truth() {
  io::Image t(kWidth, kHeight, 3, true);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const double u = double(x) / kWidth, v = double(y) / kHeight;
      double base = 0.15 + 0.5 * v;
      if (u < 0.2) base *= 0.1;                                              // dark
      if (std::hypot(u - 0.65, v - 0.35) < 0.12) base = 2.5;                 // bright
      if (u > 0.85 && v > 0.5) base = 0.8 * (0.5 + 0.5 * std::sin(40 * u));  // texture
      t.at(x, y, 0) = float(base * (0.9 + 0.2 * u));
      t.at(x, y, 1) = float(base * 0.8);
      t.at(x, y, 2) = float(base * (0.7 + 0.2 * v));
    }
  return t;
}

// A noisy reference built from kSamples samples per pixel-channel: the mean, the variance of the
// mean (sample variance / N) and the means of the first and second halves of the samples.
struct Synthetic {
  io::Image truth, mean, variance, half_a, half_b;
  NoisyReference reference() const { return {mean, variance, half_a, half_b}; }
};

// sample(truth value, sample index, pixel-channel index) -> one sample, unbiased for the truth.
using Sampler = std::function<double(double, int, size_t)>;

Synthetic make_reference(const Sampler& sample, int samples = kSamples) {
  Synthetic s;
  s.truth = truth();
  s.mean = s.variance = s.half_a = s.half_b = io::Image(kWidth, kHeight, 3, true);
  for (size_t i = 0; i < s.truth.pixels.size(); ++i) {
    double sum = 0, sum_sq = 0, first = 0;
    for (int k = 0; k < samples; ++k) {
      const double v = sample(s.truth.pixels[i], k, i);
      sum += v;
      sum_sq += v * v;
      if (k < samples / 2) first += v;
    }
    const double mean = sum / samples;
    s.mean.pixels[i] = float(mean);
    s.half_a.pixels[i] = float(first / (samples / 2));
    s.half_b.pixels[i] = float((sum - first) / (samples / 2));
    const double sample_variance = (sum_sq - samples * mean * mean) / (samples - 1);
    s.variance.pixels[i] = float(std::max(0.0, sample_variance) / samples);
  }
  return s;
}

// Uniform and standard normal draws from a 64-bit Mersenne Twister, written out: the standard
// library's distributions compute a long-double logarithm of the engine's range in every draw
// (generate_canonical), which in the sanitized build's unoptimised test program was half of this
// suite's time (tens of millions of draws).
class Draws {
 public:
  explicit Draws(uint64_t seed) : engine_(seed) {}
  double uniform() { return double(engine_() >> 11) * 0x1p-53; }  // [0, 1), 53 bits
  // Marsaglia's polar method: two normals from a point uniform in the unit disk.
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double x, y, r2;
    do {
      x = 2 * uniform() - 1;
      y = 2 * uniform() - 1;
      r2 = x * x + y * y;
    } while (r2 >= 1 || r2 == 0);
    const double scale = std::sqrt(-2 * std::log(r2) / r2);
    spare_ = x * scale, has_spare_ = true;
    return y * scale;
  }

 private:
  std::mt19937_64 engine_;
  double spare_ = 0;
  bool has_spare_ = false;
};

// Independent references of one kind: seed -> reference.
using Family = std::function<Synthetic(uint64_t seed)>;

// White Gaussian noise, 40% of the value per sample plus a little everywhere (7% per pixel-channel
// at 32 samples).
Synthetic gaussian_reference(uint64_t seed) {
  Draws draws(seed);
  return make_reference(
      [&](double t, int, size_t) { return t + (0.4 * t + 0.02) * draws.normal(); });
}

// A path tracer that finds the light rarely: a sample is t / p with probability p, else 0 (an
// unbiased, strongly skewed estimator). 256 samples: 15% relative error per pixel-channel.
Synthetic firefly_reference(uint64_t seed) {
  Draws draws(seed);
  return make_reference(
      [&](double t, int, size_t) { return draws.uniform() < 0.15 ? t / 0.15 : 0.0; }, 256);
}

// Photon-density-like noise: every sample's error is a smooth random field (bilinear from a grid of
// 8-pixel cells, shared by the colour channels), so neighbouring pixels err together.
Synthetic correlated_reference(uint64_t seed) {
  constexpr int cell = 8, gw = kWidth / cell + 2, gh = kHeight / cell + 2;
  Draws draws(seed);
  std::vector<std::vector<double>> fields(kSamples, std::vector<double>(size_t(gw * gh)));
  for (auto& f : fields)
    for (double& v : f) v = draws.normal();
  auto field = [&](int k, size_t i) {
    const size_t pixel = i / 3;
    const double x = double(pixel % kWidth) / cell, y = double(pixel / kWidth) / cell;
    const int x0 = int(x), y0 = int(y);
    const double fx = x - x0, fy = y - y0;
    const auto& f = fields[size_t(k)];
    auto at = [&](int a, int b) { return f[size_t(b * gw + a)]; };
    return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
           fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
  };
  return make_reference(
      [&](double t, int k, size_t i) { return t + (0.5 * t + 0.02) * field(k, i); });
}

// The floor is an expectation over the reference's noise, E m(R, T): both it and its estimate are
// averaged over independent references (one image's score varies with its noise, most where a few
// bright, correlated blotches dominate).
struct Averages {
  Scores floor, actual;
};
Averages average_over(const Family& family, int references) {
  Averages avg;
  double floor_display_mse = 0, actual_display_mse = 0;
  for (int k = 0; k < references; ++k) {
    const Synthetic s = family(uint64_t(100 + k));
    const Scores f = noise_floor(s.reference()).scores, a = evaluate(s.mean, s.truth);
    for (auto [sum, v] : {std::pair{&avg.floor, &f}, std::pair{&avg.actual, &a}}) {
      sum->flip.mean += v->flip.mean / references;
      sum->ssim += v->ssim / references;
      sum->rmse += v->rmse * v->rmse / references;  // mean squares, then the root
      sum->relmse += v->relmse / references;
      sum->mae += v->mae / references;
    }
    floor_display_mse += std::pow(10.0, -*f.psnr / 10) / references;
    actual_display_mse += std::pow(10.0, -*a.psnr / 10) / references;
  }
  avg.floor.rmse = std::sqrt(avg.floor.rmse);
  avg.actual.rmse = std::sqrt(avg.actual.rmse);
  avg.floor.psnr = -10 * std::log10(floor_display_mse);
  avg.actual.psnr = -10 * std::log10(actual_display_mse);
  return avg;
}

// The floor predicts each metric of m(R, T) within `tol` relative (FLIP, RMSE, relMSE, MAE) or
// `tol_db` (PSNR). SSIM's floor (ssim_of_truth) is biased towards similarity: the window variance
// of the true image, recovered as max(0, vx - vd), is clamped where noise alone made vx, so 1 -
// SSIM comes out low; it must lie in [ssim_low, 1] times the truth's 1 - SSIM.
void expect_floor_predicts(const Scores& floor, const Scores& actual, double tol, double tol_db,
                           double ssim_low, const char* what) {
  SCOPED_TRACE(what);
  std::printf(
      "%-12s FLIP %.4f (actual %.4f)  1-SSIM %.4f (%.4f)  PSNR %.2f (%.2f)  RMSE %.4g (%.4g)"
      "  relMSE %.4g (%.4g)  MAE %.4g (%.4g)\n",
      what, floor.flip.mean, actual.flip.mean, 1 - floor.ssim, 1 - actual.ssim, *floor.psnr,
      *actual.psnr, floor.rmse, actual.rmse, floor.relmse, actual.relmse, floor.mae, actual.mae);
  EXPECT_NEAR(floor.flip.mean / actual.flip.mean, 1.0, tol) << "FLIP";
  const double ssim_ratio = (1 - floor.ssim) / (1 - actual.ssim);
  EXPECT_GE(ssim_ratio, ssim_low) << "SSIM";
  EXPECT_LE(ssim_ratio, 1.0) << "SSIM";
  ASSERT_TRUE(floor.psnr && actual.psnr);
  EXPECT_NEAR(*floor.psnr, *actual.psnr, tol_db) << "PSNR";
  EXPECT_NEAR(floor.rmse / actual.rmse, 1.0, tol) << "RMSE";
  EXPECT_NEAR(floor.relmse / actual.relmse, 1.0, tol) << "relMSE";
  EXPECT_NEAR(floor.mae / actual.mae, 1.0, tol) << "MAE";
}

TEST(NoiseFloor, PredictsTheScoreOfTheTruthUnderGaussianNoise) {
  const Averages a = average_over(gaussian_reference, 4);
  expect_floor_predicts(a.floor, a.actual, 0.05, 0.2, 0.8, "gaussian");
  // The variance image and the halves estimate the same mean variance.
  const Synthetic s = gaussian_reference(1);
  const NoiseFloor floor = noise_floor(s.reference());
  EXPECT_NEAR(floor.mse_from_halves / floor.mse, 1.0, 0.05);
  // Not the floor: the metric between the two halves, whose difference has twice the amplitude of
  // the full mean's error (RMSE exactly 2x; FLIP saturates, so less).
  const Scores halves = evaluate(s.half_a, s.half_b), actual = evaluate(s.mean, s.truth);
  std::printf("half vs half: FLIP %.4f, RMSE %.4g; truth vs mean: FLIP %.4f, RMSE %.4g\n",
              halves.flip.mean, halves.rmse, actual.flip.mean, actual.rmse);
  EXPECT_NEAR(halves.rmse / actual.rmse, 2.0, 0.1);
  EXPECT_GT(halves.flip.mean / actual.flip.mean, 1.3);
}

TEST(NoiseFloor, PredictsTheScoreOfTheTruthUnderFireflies) {
  const Averages a = average_over(firefly_reference, 2);
  expect_floor_predicts(a.floor, a.actual, 0.05, 0.2, 0.8, "fireflies");
}

TEST(NoiseFloor, PredictsTheScoreOfTheTruthUnderCorrelatedNoise) {
  const Averages a = average_over(correlated_reference, 8);
  expect_floor_predicts(a.floor, a.actual, 0.05, 0.2, 0.55, "correlated");
}

TEST(NoiseFloor, UnbiasedErrorsRecoverTheErrorAgainstTheTruth) {
  const Synthetic s = gaussian_reference(1);
  // A technique 10% too bright everywhere: its error against the truth is known exactly.
  io::Image test = s.truth;
  for (float& v : test.pixels) v *= 1.1f;
  const Scores against_truth = evaluate(s.truth, test);
  const Scores against_reference = evaluate(s.mean, test);
  const UnbiasedErrors unbiased = unbiased_errors(s.reference(), test);
  const double true_mse = against_truth.rmse * against_truth.rmse;
  const double raw_mse = against_reference.rmse * against_reference.rmse;
  std::printf(
      "MSE: truth %.5g, raw %.5g, unbiased %.5g; relMSE: truth %.5g, raw %.5g, unbiased %.5g\n",
      true_mse, raw_mse, unbiased.mse, against_truth.relmse, against_reference.relmse,
      unbiased.relmse);
  // The raw scores carry the reference's noise (this is what makes the test able to fail) ...
  EXPECT_GT(raw_mse / true_mse, 1.3);
  EXPECT_GT(against_reference.relmse / against_truth.relmse, 1.3);
  // ... the unbiased ones do not.
  EXPECT_NEAR(unbiased.mse / true_mse, 1.0, 0.05);
  EXPECT_NEAR(unbiased.relmse / against_truth.relmse, 1.0, 0.05);
}

TEST(NoiseFloor, ANoiselessReferenceHasZeroFloors) {
  const io::Image t = truth();
  const io::Image zero(kWidth, kHeight, 3, true);
  const NoiseFloor f = noise_floor({t, zero, t, t});
  EXPECT_EQ(f.scores.flip.mean, 0.0);
  EXPECT_NEAR(f.scores.ssim, 1.0, 1e-12);
  EXPECT_FALSE(f.scores.psnr);
  EXPECT_TRUE(f.scores.identical);
  EXPECT_EQ(f.scores.rmse, 0.0);
  EXPECT_EQ(f.scores.relmse, 0.0);
  EXPECT_EQ(f.mse_from_halves, 0.0);
  const UnbiasedErrors e = unbiased_errors({t, zero, t, t}, t);
  EXPECT_EQ(e.mse, 0.0);
  EXPECT_EQ(e.relmse, 0.0);
}

TEST(NoiseFloor, BadInputsThrowInputError) {
  const io::Image t = truth();
  const io::Image small(kWidth / 2, kHeight, 3, true), grey(kWidth, kHeight, 1, true);
  io::Image ldr = t;
  ldr.linear = false;
  io::Image nan = t;
  nan.pixels[5] = NAN;
  EXPECT_THROW(noise_floor({t, small, t, t}), InputError);
  EXPECT_THROW(noise_floor({t, grey, t, t}), InputError);
  EXPECT_THROW(noise_floor({ldr, ldr, ldr, ldr}), InputError);
  EXPECT_THROW(noise_floor({t, nan, t, t}), InputError);
  EXPECT_THROW(noise_floor({t, t, nan, t}), InputError);
  EXPECT_THROW(noise_floor({t, t, t, small}), InputError);
  EXPECT_THROW(unbiased_errors({t, t, t, t}, small), InputError);
}

}  // namespace noise_floor_test
}  // namespace pb::metrics
