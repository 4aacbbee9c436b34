// Does an image estimate converge to a reference? A per-pixel-channel two-sided Z-test of two
// independent estimates, each a mean image with the variance of that mean, with a Sidak-corrected
// level for the whole image, the design of Mitsuba 3's render tests (a render's mean and variance
// against a reference's; any pixel beyond the corrected level fails the image). The seed axis
// (run/seed_stats.h) tests a technique's mean over K seeds, variance S^2 / K, against the
// reference's mean and variance.
//
//   z_i = (a_i - b_i) / sqrt(var_a_i + var_b_i),  p_i = P(|Z| >= |z_i|) = erfc(|z_i| / sqrt 2)
//
// Under the hypothesis that both estimate the same image, each p_i is uniform on [0, 1]; with N
// pixel-channels, rejecting when min p_i < 1 - (1 - alpha)^(1/N) (Sidak) rejects an equal pair with
// probability alpha when the tests are independent (at most about alpha when they are not). The
// image's p-value is the Sidak-adjusted smallest one, 1 - (1 - min p_i)^N: the test rejects exactly
// when it is below alpha.
#pragma once

#include <cstddef>

#include "io/image.h"

namespace pb::metrics {

struct ZTestResult {
  size_t tested = 0;    // pixel-channels compared (colour channels of every pixel)
  size_t rejected = 0;  // those with p_i below the Sidak level
  // Pixel-channels with no variance on either side: equal values pass (p_i = 1), different ones
  // reject (p_i = 0): two exact values that differ are not the same image.
  size_t exact = 0;
  size_t exact_mismatches = 0;  // of those, the ones whose two values differ
  double alpha = 0, sidak_level = 0;
  double min_p = 1;    // the smallest p_i
  double p_value = 1;  // 1 - (1 - min_p)^tested
  bool equal() const { return p_value >= alpha; }
  // The share of the pixel-channels with a variance that reject (the exact ones left out): for a
  // check that tolerates a few, as the reference renderer's agreement tests do.
  double rejected_share_with_variance() const {
    const size_t with_variance = tested - exact;
    return with_variance ? double(rejected - exact_mismatches) / double(with_variance) : 0.0;
  }
};

// var_a and var_b are the variances of mean_a and mean_b (of the means, not of one sample), with
// 1, 3 or 4 channels like the means (colour channels only are compared). Throws pb::InputError
// when the sizes differ, a variance is negative, a value is not finite, or alpha is not in (0, 1).
ZTestResult z_test(const io::Image& mean_a, const io::Image& var_a, const io::Image& mean_b,
                   const io::Image& var_b, double alpha = 0.01);

}  // namespace pb::metrics
