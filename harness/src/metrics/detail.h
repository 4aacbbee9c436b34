// Internals shared by the metric sources: input checks, planar copies of images, and the
// vectorisable maths the hot loops use. Not part of the metrics API.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>
#include <string_view>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "io/image.h"

// Hot loops are compiled for AVX-512, AVX2 and baseline x86-64 and the best one is picked when the
// library loads (GCC function multi-versioning), so the build needs no -march flag and still uses the
// wide vector units where they exist. Functions they call inline are compiled for the same target.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define PB_METRICS_KERNEL \
  __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define PB_METRICS_KERNEL
#endif

// No fused multiply-adds: GCC contracts a * b + c differently in a loop's vector body and in its
// scalar remainder, whose split depends on pointer alignment, so identical inputs at different
// addresses (a reference and its copy) would differ in the last bit, and FLIP's (x - y)^0.7
// turns a last-bit difference into a visible error. Without contraction every target clone gives
// the same bits.
#pragma GCC optimize("fp-contract=off")

namespace pb::metrics::detail {

// Checks that two images can be compared (same size, same encoding, 1/3/4 channels, finite
// values); throws pb::InputError naming `metric` otherwise.
void check_pair(const io::Image& reference, const io::Image& test, std::string_view metric);

// Colour channels of an image, one plane each (row-major), alpha dropped, grey replicated.
template <typename T>
struct Planes {
  int width = 0, height = 0;
  std::vector<T> c[3];
};

// The values as stored (float) and as linear radiance or display values (double); 8-bit LDR
// values are snapped to k / 255 exactly, so the results match tools that read the file as uint8.
Planes<float> stored_planes(const io::Image& image);
Planes<double> display_planes(const io::Image& image);  // LDR as is; HDR clamp + sRGB encode
Planes<double> linear_planes(const io::Image& image);   // HDR as is; LDR sRGB decoded

// SSIM of display planes (ssim.cpp), for evaluate() to share the planes with PSNR.
double ssim_planes(const Planes<double>& reference, const Planes<double>& test);

// Deterministic parallel sum of row_sum(y) over rows [begin, end): the rows run in parallel, their
// sums are added in row order, so the result does not depend on how the rows were scheduled.
template <typename RowSum>
double sum_rows(int begin, int end, const RowSum& row_sum) {
  if (end <= begin) return 0.0;
  std::vector<double> sums(size_t(end - begin));
  tbb::parallel_for(tbb::blocked_range<int>(begin, end), [&](const tbb::blocked_range<int>& r) {
    for (int y = r.begin(); y < r.end(); ++y) sums[size_t(y - begin)] = row_sum(y);
  });
  double total = 0;
  for (double s : sums) total += s;
  return total;
}

// ---- Vectorisable elementary functions -----------------------------------------------------------
// The loops over pixels call these instead of std::pow/std::cbrt, which GCC cannot vectorise. Their
// relative error is about 2e-7 (a few float ulps), far below what the metrics resolve.

// log2(x) for finite x > 0 (normal numbers). x = 2^e * m with m in [sqrt(1/2), sqrt(2)), and
// log2(m) = (2 / ln 2) * atanh(s), s = (m - 1) / (m + 1), |s| <= 0.172, summed to s^9.
inline float fast_log2(float x) {
  const int32_t bits = std::bit_cast<int32_t>(x);
  const int32_t e = (bits - 0x3F3504F3) >> 23;  // 0x3F3504F3 is sqrt(1/2)
  const float m = std::bit_cast<float>(bits - (e << 23));
  const float s = (m - 1.f) / (m + 1.f);
  const float s2 = s * s;
  const float series = s2 * (1.f / 3.f + s2 * (1.f / 5.f + s2 * (1.f / 7.f + s2 * (1.f / 9.f))));
  return float(e) + 2.88539008f * (s + s * series);  // 2 / ln 2
}

// 2^x for x in [-126, 128): 2^round(x) by building the exponent bits, times e^(f ln 2) for the
// remainder |f| <= 1/2 as a degree-7 Taylor polynomial (truncation error 6e-9).
inline float fast_exp2(float x) {
  x = std::fmin(std::fmax(x, -126.f), 127.f);
  const float k = std::floor(x + 0.5f);
  const float t = (x - k) * 0.693147181f;
  float p = 1.f / 5040;
  p = 1.f / 720 + t * p;
  p = 1.f / 120 + t * p;
  p = 1.f / 24 + t * p;
  p = 1.f / 6 + t * p;
  p = 1.f / 2 + t * p;
  p = 1.f + t * p;
  p = 1.f + t * p;
  return p * std::bit_cast<float>((int32_t(k) + 127) << 23);
}

// x^y for x >= 0; 0^y is 0 for y > 0 and 1 for y == 0, as std::pow gives.
inline float fast_pow(float x, float y) {
  const float r = fast_exp2(y * fast_log2(std::fmax(x, 1e-30f)));
  return x > 1e-30f ? r : (y == 0.f ? 1.f : 0.f);
}

inline float fast_cbrt(float x) { return fast_exp2(fast_log2(x) * (1.f / 3.f)); }  // x > 0

}  // namespace pb::metrics::detail
