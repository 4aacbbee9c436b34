// Internals shared by the metric sources: input checks, row conversion, and the vectorisable maths
// the hot loops use. Not part of the metrics API.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <cstdint>
#include <string_view>
#include <vector>

#include "io/image.h"
#include "metrics/metrics.h"

// Hot loops come in three builds, one per x86-64 level: baseline (SSE2, 2 doubles a vector),
// x86-64-v3 (AVX2 with FMA, 4) and x86-64-v4 (AVX-512, 8). The widest the CPU runs is picked at the
// first call (metrics.h: vector_path) and can be changed by use_vector_path, so a bench or a test
// can run the AVX2 build on an AVX-512 machine. The build needs no -march flag. A kernel is a
// struct with `template <class Isa> static R run(...)`, always inlined into one wrapper per level
// (below), so everything it calls inline is compiled for that level; Isa::lanes sizes its vectors
// to the level's registers (a vector wider than the registers is lowered through the stack, lane by
// lane: SSIM in 8-double vectors ran 3x slower on AVX2 than on AVX-512).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define PB_METRICS_LEVELS 1
#else
#define PB_METRICS_LEVELS 0
#endif

// No fused multiply-adds but where a kernel asks for one (madd below): GCC contracts a * b + c
// differently in a loop's vector body and in its scalar remainder, whose split depends on pointer
// alignment, so identical inputs at different addresses (a reference and its copy) would differ in
// the last bit, and FLIP's (x - y)^0.7 turns a last-bit difference into a visible error. Without
// contraction a loop gives the same bits in every build, and madd's explicit FMA is the same in
// every lane and column of one build. And no floating-point traps (we never enable them):
// otherwise GCC will not compute both sides of a select such as v <= 0.04045 ? v / 12.92 :
// pow(...) and leaves the loop scalar. Neither option changes a result.
//
// Functions defined before this pragma (std::sqrt, std::fabs, std::min, ...) have other options,
// and GCC does not inline across that difference, so the hot loops use the helpers below and
// compiler builtins only. Clang (the sanitized build) takes the standard pragma for the first and
// does not trap by default.
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#else
#pragma GCC optimize("fp-contract=off", "no-trapping-math")
#endif

namespace pb::metrics::detail {

// The levels a kernel is built for: doubles (and floats) per vector, and whether a * b + c may be
// one fused instruction (madd below).
struct Baseline {
  static constexpr int lanes = 2, float_lanes = 4;
  static constexpr bool fma = false;
};
struct Avx2 {
  static constexpr int lanes = 4, float_lanes = 8;
  static constexpr bool fma = true;
};
struct Avx512 {
  static constexpr int lanes = 8, float_lanes = 16;
  static constexpr bool fma = true;
};

// The level in use (common.cpp; an atomic read).
VectorPath active_path();

#if PB_METRICS_LEVELS
template <class Kernel, class... Args>
__attribute__((target("arch=x86-64-v4"))) auto run_avx512(Args... args) {
  return Kernel::template run<Avx512>(args...);
}
template <class Kernel, class... Args>
__attribute__((target("arch=x86-64-v3"))) auto run_avx2(Args... args) {
  return Kernel::template run<Avx2>(args...);
}
#endif
template <class Kernel, class... Args>
auto run_baseline(Args... args) {
  return Kernel::template run<Baseline>(args...);
}

// Kernel::run<Isa>(args...) built for the level in use. Arguments are passed by value (pointers,
// sizes, small structs by pointer).
template <class Kernel, class... Args>
auto dispatch(Args... args) {
#if PB_METRICS_LEVELS
  switch (active_path()) {
    case VectorPath::avx512:
      return run_avx512<Kernel>(args...);
    case VectorPath::avx2:
      return run_avx2<Kernel>(args...);
    case VectorPath::baseline:
      break;
  }
#endif
  return run_baseline<Kernel>(args...);
}

// ---- Vectors of Isa::lanes doubles (GCC vector extensions) --------------------------------------
//
// Each lane gets exactly the operations a scalar loop would do. Functions taking or returning
// vectors are always inlined into a kernel, never called across an ABI boundary, so GCC's note that
// passing AVX vectors by value "changes the ABI" does not apply to them (in the metrics sources,
// the only includers of this header).
#pragma GCC diagnostic ignored "-Wpsabi"

template <class T, int Lanes>
struct Vector {
  typedef T type __attribute__((vector_size(Lanes * sizeof(T))));
};
template <class Isa>
using DoublesOf = typename Vector<double, Isa::lanes>::type;

// A vector V from, or to, consecutive elements (doubles or floats) at p.
template <class V, class T>
[[gnu::always_inline]] inline V load(const T* p) {  // unaligned
  V v;
  __builtin_memcpy(&v, p, sizeof v);
  return v;
}
template <class T, class V>
[[gnu::always_inline]] inline void store(T* p, V v) {  // unaligned
  __builtin_memcpy(p, &v, sizeof v);
}

// a * b + c, rounded once (one FMA instruction) where the level has FMA, else twice. Either way the
// same for every lane and every column, whatever the data's alignment.
template <class Isa, class V>
[[gnu::always_inline]] inline V madd(V a, V b, V c) {
  if constexpr (Isa::fma) {
    V r;
    for (int l = 0; l < Isa::lanes; ++l) r[l] = __builtin_fma(a[l], b[l], c[l]);
    return r;
  } else {
    return a * b + c;
  }
}

// Checks that two images can be compared (same size, same encoding, 1/3/4 channels, finite
// values); throws pb::InputError naming `metric` otherwise.
void check_pair(const io::Image& reference, const io::Image& test, std::string_view metric);

// Which values a metric sees (metrics.h): display-encoded (LDR as stored, HDR clamped and sRGB
// encoded) or linear (HDR as stored, LDR sRGB decoded).
enum class Values { display, linear };

// Colour channel `channel` (0..2; a grey image gives its one channel for all three, alpha is never
// read) of row y, converted to `values`, into out[0 .. width). 8-bit LDR values are snapped to
// k / 255 exactly, so results match tools that read the file as uint8 and compute in float64.
void convert_row(const io::Image& image, int y, int channel, Values values, double* out);

// SSIM without the input checks (ssim.cpp), for evaluate(), which checks once.
double ssim_unchecked(const io::Image& reference, const io::Image& test);

// The SSIM floor of a reference (ssim.cpp; noise_floor.h): the expected SSIM of the true image
// against `mean`, from the mean and its two half-estimates. Checked by the caller.
double ssim_of_truth(const io::Image& mean, const io::Image& half_a, const io::Image& half_b);

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

// ---- Vectorisable elementary functions ---------------------------------------------------------
//
// The loops over pixels call these instead of std::pow/std::cbrt/std::fmin, which GCC turns into
// library calls and so cannot vectorise. The transcendental ones have a relative error of about
// 2e-7 (a few float ulps), far below what the metrics resolve.

[[gnu::always_inline]] inline float abs_f(float v) { return __builtin_fabsf(v); }
[[gnu::always_inline]] inline double abs_d(double v) { return __builtin_fabs(v); }

// min/max as compare-and-select (one vector instruction each; std::fmin's NaN rules need a call).
[[gnu::always_inline]] inline float min_f(float a, float b) { return b < a ? b : a; }
[[gnu::always_inline]] inline float max_f(float a, float b) { return a < b ? b : a; }
[[gnu::always_inline]] inline float clamp01(float v) { return min_f(max_f(v, 0.f), 1.f); }

// log2(x) for finite x > 0 (normal numbers). x = 2^e * m with m in [sqrt(1/2), sqrt(2)), and
// log2(m) = (2 / ln 2) * atanh(s), s = (m - 1) / (m + 1), |s| <= 0.172, summed to s^9.
[[gnu::always_inline]] inline float fast_log2(float x) {
  const int32_t bits = __builtin_bit_cast(int32_t, x);
  const int32_t e = (bits - 0x3F3504F3) >> 23;  // 0x3F3504F3 is sqrt(1/2)
  const float m = __builtin_bit_cast(float, bits - (e << 23));
  const float s = (m - 1.f) / (m + 1.f);
  const float s2 = s * s;
  const float series = s2 * (1.f / 3.f + s2 * (1.f / 5.f + s2 * (1.f / 7.f + s2 * (1.f / 9.f))));
  return float(e) + 2.88539008f * (s + s * series);  // 2 / ln 2
}

// 2^x for x in [-126, 127]: 2^k, k = round(x), from the exponent bits, times e^(f ln 2) for the
// remainder |f| <= 1/2 as a degree-7 Taylor polynomial (truncation error 6e-9).
[[gnu::always_inline]] inline float fast_exp2(float x) {
  x = min_f(max_f(x, -126.f), 127.f);
  const int32_t k = int32_t(x + 128.5f) - 128;  // round to nearest; truncation of a positive value
  const float t = (x - float(k)) * 0.693147181f;
  float p = 1.f / 5040;
  p = 1.f / 720 + t * p;
  p = 1.f / 120 + t * p;
  p = 1.f / 24 + t * p;
  p = 1.f / 6 + t * p;
  p = 1.f / 2 + t * p;
  p = 1.f + t * p;
  p = 1.f + t * p;
  return p * __builtin_bit_cast(float, (k + 127) << 23);
}

// x^y for x >= 0; 0^y is 0 for y > 0 and 1 for y == 0, as std::pow gives.
[[gnu::always_inline]] inline float fast_pow(float x, float y) {
  const float r = fast_exp2(y * fast_log2(max_f(x, 1e-30f)));
  return x > 1e-30f ? r : (y == 0.f ? 1.f : 0.f);
}

// sqrt(x) for x >= 0 as x / sqrt(x), the reciprocal root from the bit-level estimate
// 0x5F375A86 - bits / 2 (relative error <= 0.18%) and two Newton steps (error ~1e-11, so the
// result is within a few ulps). std::sqrt would be exact, but without -fno-math-errno on the
// command line GCC guards it with an errno branch and leaves the loop scalar.
[[gnu::always_inline]] inline float sqrt_f(float x) {
  float y = __builtin_bit_cast(float, 0x5F375A86 - (__builtin_bit_cast(int32_t, x) >> 1));
  y = y * (1.5f - 0.5f * x * y * y);
  y = y * (1.5f - 0.5f * x * y * y);
  const float root = x * y;
  return x > 0.f ? root : 0.f;
}

[[gnu::always_inline]] inline float fast_cbrt(float x) {  // x > 0
  return fast_exp2(fast_log2(x) * (1.f / 3.f));
}

// sRGB transfer functions (IEC 61966-2-1) on [0, 1].
[[gnu::always_inline]] inline float srgb_decode_fast(float v) {
  const float curve = fast_pow((v + 0.055f) / 1.055f, 2.4f);
  return v <= 0.04045f ? v / 12.92f : curve;
}
[[gnu::always_inline]] inline float srgb_encode_fast(float v) {
  const float curve = 1.055f * fast_pow(v, 1.f / 2.4f) - 0.055f;
  return v <= 0.0031308f ? 12.92f * v : curve;
}

}  // namespace pb::metrics::detail
