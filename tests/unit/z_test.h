// Comparing two independent estimates of one image by their stored variances (the reference
// renderer's ReferenceImage): a per-pixel-channel Z-test with a Sidak-corrected threshold, as
// Mitsuba 3's test suite compares its renders with references (mean + variance images).
#pragma once

#include <cmath>
#include <cstddef>

#include "io/image.h"

namespace pb::trace::ztest {

// The |z| above which one of n independent two-sided tests rejects, for a family-wise false
// rejection rate `alpha`: per-test level 1 - (1 - alpha)^(1/n) (Sidak), inverted through
// P(|Z| > z) = erfc(z / sqrt 2) by bisection.
inline double sidak_threshold(double alpha, size_t n) {
  double per_test = -std::expm1(std::log1p(-alpha) / double(n));
  double lo = 0, hi = 40;
  for (int i = 0; i < 200; ++i) {
    double mid = 0.5 * (lo + hi);
    (std::erfc(mid / std::sqrt(2.0)) > per_test ? lo : hi) = mid;
  }
  return lo;
}

struct Outcome {
  size_t tested = 0, passed = 0;  // pixel-channels with a variance, and those within the threshold
  size_t zero_variance_mismatches = 0;  // a pixel-channel both call exact but on different values
  double threshold = 0;
  double pass_fraction() const { return tested ? double(passed) / double(tested) : 1.0; }
};

// z = (a - b) / sqrt(var_a + var_b) per pixel-channel against the Sidak threshold for all of them.
inline Outcome compare(const io::Image& mean_a, const io::Image& var_a, const io::Image& mean_b,
                       const io::Image& var_b, double alpha = 0.01) {
  Outcome out;
  out.threshold = sidak_threshold(alpha, mean_a.pixels.size());
  for (size_t i = 0; i < mean_a.pixels.size(); ++i) {
    double diff = double(mean_a.pixels[i]) - mean_b.pixels[i];
    double var = double(var_a.pixels[i]) + var_b.pixels[i];
    if (!(var > 0)) {
      if (std::abs(diff) > 1e-6 * (1 + std::abs(double(mean_a.pixels[i]))))
        ++out.zero_variance_mismatches;
      continue;
    }
    ++out.tested;
    out.passed += std::abs(diff) / std::sqrt(var) <= out.threshold;
  }
  return out;
}

}  // namespace pb::trace::ztest
