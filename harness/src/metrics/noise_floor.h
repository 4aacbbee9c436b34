// Noise floors: what a reference's own Monte Carlo noise scores, so that a technique's score can be
// read against it.
//
// A reference R is an estimate of the true image T: R = T + e, with e of zero mean (the noise; any
// bias, such as SPPM's kernel bias or a path-depth cut, is not noise and no floor sees it) and of
// per pixel-channel variance Var(R), "the variance of the mean". A technique X is scored as
// m(R, X). Its floor is
//
//     floor(m) = E_R[ m(R, T) ],
//
// the score that a technique whose output IS the true image would get, in expectation, against this
// reference. A score near its floor does not measure the technique: the reference's noise made it.
//
// How each floor is obtained, from the variance image Var R and two independent half-estimates
// H1, H2 (means of disjoint halves of the samples, R = (H1 + H2) / 2). The half-difference
// d = (H1 - H2) / 2 has exactly the variance of R - T (Var H = 2 Var R, so Var d = Var R) and
// carries the renderer's own noise: its heavy tails (fireflies) and its spatial correlation
// (photon-density blotches), which FLIP and SSIM see differently from white noise.
//   RMSE, relMSE   closed form from the variance image, on linear values as these metrics use them:
//                    rmse_floor   = sqrt(mean(Var R))      (E mean((R - T)^2) = mean(Var R)
//                    exactly) relmse_floor = mean(Var R (w(R) + Var R w''(R)))
//                  relMSE weighs by w(R) = 1 / (R^2 + 0.01), a function of the noisy R itself; the
//                  second term is that dependence to second order in the noise (noise_floor.cpp).
//   PSNR           10 log10(1 / mean(((D(H1) - D(H2)) / 2)^2)), D the display encoding PSNR sees:
//                  the display-encoded noise power of R, estimated like the MSE from the halves.
//   FLIP (and MAE) no closed form (colour transforms, feature filters, pooling): the metric between
//                  R and R perturbed by d, averaged over both signs,
//                    flip_floor = ( FLIP(R, R + d) + FLIP(R, R - d) ) / 2  (R + d = H1, R - d = H2)
//                  R stays the reference argument, so the HDR-FLIP exposure range scoring derives
//                  from it is the one scoring uses. That the proxy "truth" R +- d carries noise of
//                  its own is a second-order effect for FLIP, a function of the difference.
//   SSIM           not a function of the difference: noise present in both arguments counts as
//                  shared structure, so SSIM(R, R + d) overstates the floor's similarity (in a flat
//                  noisy region it gives ~2/3 where the truth scores C2 / (noise + C2)). Instead
//                  the true image's window statistics are recovered from R's by taking off d's
//                  (ssim.cpp, ssim_of_truth: E vy = vx - E vd, E vxy = vy, E uy = ux). Where noise
//                  alone made R's window variance, the estimate max(0, vx - vd) is clamped, so this
//                  floor leans to similarity: 1 - SSIM comes out 13-15% low for white noise and 35%
//                  low for noise correlated over 8 pixels (noise_floor_test.cpp). FLIP, PSNR, RMSE
//                  and relMSE floors are within 3% of the truth there (0.2 dB for PSNR).
//   Not used: the metric between the two halves, m(H1, H2). Their difference has variance
//   4 Var(R), twice the amplitude of the full reference's error, so it overstates the floor of a
//   score against the full mean (for MSE exactly 4x; tests/unit/noise_floor_test.cpp measures the
//   FLIP excess). Nor Gaussian noise drawn from the variance image: white, so blind to correlated
//   noise, and of no help with SSIM.
// Bias (SPPM's kernel blur, a path-depth cut) is not noise: no floor sees it.
#pragma once

#include "io/image.h"
#include "metrics/metrics.h"

namespace pb::metrics {

// A reference as a Monte Carlo estimate. All images linear, of one size and channel count.
struct NoisyReference {
  const io::Image& mean;
  const io::Image& variance;  // per pixel-channel variance of `mean` (not of one sample)
  const io::Image& half_a;    // means of two independent halves of the samples
  const io::Image& half_b;
};

struct NoiseFloor {
  // The floor of each metric of Scores: flip, ssim, psnr (empty, with identical = true, when the
  // halves agree exactly: a noiseless reference), mae, rmse, relmse.
  Scores scores;
  double mse = 0;              // mean(Var R): the floor of the linear MSE (rmse_floor^2)
  double mse_from_halves = 0;  // mean(((H1 - H2) / 2)^2): the halves' estimate of the same mean
                               // variance, a check on the variance image
};

// The floors of every metric for `reference` (throws pb::InputError on mismatched, non-finite or
// LDR images); FLIP's only when `selection` asks for it (two FLIP evaluations: most of the floors'
// time), else scores.flip stays zero. `options`: FLIP's, as scoring uses them.
NoiseFloor noise_floor(const NoisyReference& reference, const FlipOptions& options = {},
                       const MetricSelection& selection = {});

// Squared errors of a test image X against the true image, estimated from the noisy reference.
// For X independent of R's noise, E mean((X - R)^2) = mean((X - T)^2) + mean(Var R), so
//   mse    = mean((X - R)^2 - Var R)                    unbiased for mean((X - T)^2)
//   relmse = relMSE(R, X) less mean(Var R (w(R) - 2 (X - R) w'(R))), w(R) = 1 / (R^2 + 0.01):
//            the weight is a function of R, so R's noise also enters through the weight's slope
//            (noise_floor.cpp); an estimate of mean((X - T)^2 / (T^2 + 0.01)), within 3% of it on
//            references with up to 15% error per pixel (within 5x of it at 40%: none is reliable)
// Either is negative when the score lies within the reference's noise.
struct UnbiasedErrors {
  double mse = 0, relmse = 0;
};
UnbiasedErrors unbiased_errors(const NoisyReference& reference, const io::Image& test);

}  // namespace pb::metrics
