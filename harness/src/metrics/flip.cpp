// FLIP: LDR-FLIP (Andersson et al., HPG 2020) and HDR-FLIP (Andersson et al., EG 2021), matching
// the NVIDIA reference tool v1.6 (its default viewing condition, tone mappers, exposure range and
// pooling).
//
// Per pixel, FLIP compares a colour difference (the images filtered by contrast sensitivity
// functions in the YCxCz opponent space, then the HyAB distance of Hunt-adjusted CIELab values)
// with a feature difference (edges and points found by first and second derivatives of a Gaussian
// on the achromatic channel): error = colour_difference ^ (1 - feature_difference). HDR-FLIP tone
// maps both images at several exposures and keeps each pixel's largest LDR-FLIP error.
//
// The work is one fused pass per image pair (and per exposure), tile by tile: input rows are
// converted to YCxCz into a small ring as the tile moves down, the separable filters run vertically
// (over the ring) and then horizontally (on one padded row), and the per-pixel differences follow
// while the row is still in cache; nothing image-sized is written but the error map. Clamp-to-edge
// borders in both directions make vertical-then-horizontal equal to the reference's opposite order.
#include <fmt/format.h>
#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "metrics/detail.h"
#include "metrics/metrics.h"
#include "photonbench/error.h"

namespace pb::metrics {
namespace {

using detail::abs_f;
using detail::clamp01;
using detail::fast_cbrt;
using detail::fast_pow;
using detail::max_f;
using detail::sqrt_f;

// HPG 2020's constants: colour-difference exponent q_c, the error p_c * cmax where the colour
// error's remapping changes slope and the value p_t it maps to, feature filter width w (degrees)
// and feature exponent q_f.
constexpr float kQc = 0.7f, kPc = 0.4f, kPt = 0.95f, kW = 0.082f, kQf = 0.5f;
constexpr float kPi = 3.14159265358979f;

// The contrast sensitivity functions of Y, Cx and Cz as sums of two Gaussians
// a1 sqrt(pi / b1) exp(-pi^2 x^2 / b1) + a2 sqrt(pi / b2) exp(-pi^2 x^2 / b2), x in degrees
// (HPG 2020, the colour pipeline's spatial filtering).
struct Csf {
  float a1, b1, a2, b2;
};
constexpr Csf kCsfY{1.f, 0.0047f, 0.f, 1e-5f};
constexpr Csf kCsfCx{1.f, 0.0053f, 0.f, 1e-5f};
constexpr Csf kCsfCz{34.1f, 0.04f, 13.5f, 0.025f};

// CIE XYZ of the sRGB (D65) white, and its inverse: the reference white of YCxCz and CIELab.
constexpr float kWhite[3] = {0.950428545f, 1.f, 1.088900371f};
constexpr float kInvWhite[3] = {1.052156925f, 1.f, 0.918357670f};

// Tone curves of HDR-FLIP (EG 2021) as (c0 x^2 + c1 x + c2) / (c3 x^2 + c4 x + c5).
// ACES (Narkowicz's fit) carries the 0.6 that cancels its built-in pre-exposure; Hable is the
// Uncharted 2 curve; Reinhard's row only serves the exposure computation (its curve scales colour
// by 1 / (1 + luminance)).
constexpr float kToneCurves[3][6] = {
    {0.6f * 0.6f * 2.51f, 0.6f * 0.03f, 0.f, 0.6f * 0.6f * 2.43f, 0.6f * 0.59f, 0.14f},  // aces
    {0.231683f, 0.013791f, 0.f, 0.18f, 0.3f, 0.018f},                                    // hable
    {0.f, 1.f, 0.f, 0.f, 1.f, 1.f},                                                      // reinhard
};

const float* tone_curve(Tonemapper tm) { return kToneCurves[int(tm)]; }

[[gnu::always_inline]] inline float luminance(float r, float g, float b) {
  return 0.2126f * r + 0.7152f * g + 0.0722f * b;
}

// Linear sRGB to CIE XYZ (IEC 61966-2-1 primaries, D65), the matrix as exact fractions.
[[gnu::always_inline]] inline void rgb_to_xyz(float r, float g, float b, float& x, float& y,
                                              float& z) {
  x = (10135552.f / 24577794.f) * r + (8788810.f / 24577794.f) * g + (4435075.f / 24577794.f) * b;
  y = (2613072.f / 12288897.f) * r + (8788810.f / 12288897.f) * g + (887015.f / 12288897.f) * b;
  z = (1425312.f / 73733382.f) * r + (8788810.f / 73733382.f) * g + (70074185.f / 73733382.f) * b;
}

[[gnu::always_inline]] inline void xyz_to_rgb(float x, float y, float z, float& r, float& g,
                                              float& b) {
  r = 3.241003275f * x - 1.537398934f * y - 0.498615861f * z;
  g = -0.969224334f * x + 1.875930071f * y + 0.041554224f * z;
  b = 0.055639423f * x - 0.204011202f * y + 1.057148933f * z;
}

// Linear RGB in [0, 1] to YCxCz, the linearised CIELab of Zhang and Wandell that HPG 2020 filters
// in.
[[gnu::always_inline]] inline void rgb_to_ycxcz(float r, float g, float b, float& yy, float& cx,
                                                float& cz) {
  float x, y, z;
  rgb_to_xyz(r, g, b, x, y, z);
  x *= kInvWhite[0];
  z *= kInvWhite[2];
  yy = 116.f * y - 16.f;
  cx = 500.f * (x - y);
  cz = 200.f * (y - z);
}

// CIELab's f(t): the cube root above (6/29)^3, a line below.
[[gnu::always_inline]] inline float lab_f(float t) {
  constexpr float delta = 6.f / 29.f;
  constexpr float delta_cube = delta * delta * delta;
  constexpr float slope = 1.f / (3.f * delta * delta);
  const float root = fast_cbrt(t);
  return t > delta_cube ? root : t * slope + 4.f / 29.f;
}

// A filtered YCxCz value back to linear RGB, clamped to the displayable [0, 1] (HPG 2020,
// the colour pipeline), then to CIELab with Hunt's chroma adjustment a, b *= 0.01 L.
[[gnu::always_inline]] inline void ycxcz_to_hunt_lab(float yy, float cx, float cz, float& l,
                                                     float& a, float& b) {
  const float fy = (yy + 16.f) / 116.f;
  float x = (fy + cx / 500.f) * kWhite[0];
  float y = fy;
  float z = (fy - cz / 200.f) * kWhite[2];
  float r, g, bl;
  xyz_to_rgb(x, y, z, r, g, bl);
  rgb_to_xyz(clamp01(r), clamp01(g), clamp01(bl), x, y, z);
  const float lx = lab_f(x * kInvWhite[0]), ly = lab_f(y), lz = lab_f(z * kInvWhite[2]);
  l = 116.f * ly - 16.f;
  a = 0.01f * l * (500.f * (lx - ly));
  b = 0.01f * l * (200.f * (ly - lz));
}

// The largest colour distance FLIP can see, between Hunt-adjusted green and blue (HPG 2020,
// its colour metric), raised to q_c. Computed with std:: functions like the reference.
float max_colour_distance() {
  auto hunt_lab = [](float r, float g, float b) {
    float x, y, z;
    rgb_to_xyz(r, g, b, x, y, z);
    auto f = [](float t) {
      constexpr float delta = 6.f / 29.f;
      return t > delta * delta * delta ? std::pow(t, 1.f / 3.f)
                                       : t / (3.f * delta * delta) + 4.f / 29.f;
    };
    float lx = f(x * kInvWhite[0]), ly = f(y), lz = f(z * kInvWhite[2]);
    float l = 116.f * ly - 16.f;
    return std::array<float, 3>{l, 0.01f * l * 500.f * (lx - ly), 0.01f * l * 200.f * (ly - lz)};
  };
  auto green = hunt_lab(0, 1, 0), blue = hunt_lab(0, 0, 1);
  float hyab =
      std::fabs(green[0] - blue[0]) + std::sqrt((green[1] - blue[1]) * (green[1] - blue[1]) +
                                                (green[2] - blue[2]) * (green[2] - blue[2]));
  return std::pow(hyab, kQc);
}

// ---- Filters --------------------------------------------------------------------------------

struct Filters {
  int spatial_radius = 0;
  std::vector<float> y, cx, cz1, cz2;  // Cz's sum of Gaussians separates into two passes
  int feature_radius = 0;
  std::vector<float> g, dg, ddg;  // Gaussian and its first and second derivatives
};

// Samples the CSFs at 1/ppd degree steps out to three standard deviations of the widest Gaussian,
// normalised so each 2-D filter sums to 1. A sum of two 2-D Gaussians is not separable, but
// sqrt-weighted 1-D pairs are: g1(x) g1(y) + g2(x) g2(y) (the reference tool's
// separatedConvolutions note), so Cz is filtered twice and the results added.
Filters make_filters(float ppd) {
  Filters f;
  const float dx = 1.f / ppd;
  const float pi_sq = kPi * kPi;
  const float max_b = std::max({kCsfY.b1, kCsfCx.b1, kCsfCz.b1, kCsfY.b2, kCsfCx.b2, kCsfCz.b2});
  f.spatial_radius = int(std::ceil(3.f * std::sqrt(max_b / (2.f * pi_sq)) * ppd));
  const int width = 2 * f.spatial_radius + 1;
  auto gaussian = [&](float x2, float a, float b) {
    return a * std::sqrt(kPi / b) * std::exp(-pi_sq * x2 / b);
  };
  auto gaussian_sqrt = [&](float x2, float a, float b) {
    return std::sqrt(a * std::sqrt(kPi / b)) * std::exp(-pi_sq * x2 / b);
  };
  float sum_y = 0, sum_cx = 0, sum_cz1 = 0, sum_cz2 = 0;
  for (int i = 0; i < width; ++i) {
    float x = float(i - f.spatial_radius) * dx;
    float x2 = x * x;
    f.y.push_back(gaussian(x2, kCsfY.a1, kCsfY.b1));
    f.cx.push_back(gaussian(x2, kCsfCx.a1, kCsfCx.b1));
    f.cz1.push_back(gaussian_sqrt(x2, kCsfCz.a1, kCsfCz.b1));
    f.cz2.push_back(gaussian_sqrt(x2, kCsfCz.a2, kCsfCz.b2));
    sum_y += f.y.back();
    sum_cx += f.cx.back();
    sum_cz1 += f.cz1.back();
    sum_cz2 += f.cz2.back();
  }
  const float norm_cz = 1.f / std::sqrt(sum_cz1 * sum_cz1 + sum_cz2 * sum_cz2);
  for (int i = 0; i < width; ++i) {
    f.y[i] *= 1.f / sum_y;
    f.cx[i] *= 1.f / sum_cx;
    f.cz1[i] *= norm_cz;
    f.cz2[i] *= norm_cz;
  }

  // Feature detection (HPG 2020, the feature pipeline): a Gaussian of standard deviation w/2
  // degrees and its derivatives, the derivatives' positive and negative weights each normalised to
  // sum to +-1.
  const float sd = 0.5f * kW * ppd;
  f.feature_radius = int(std::ceil(3.f * sd));
  float sum_g = 0, dg_pos = 0, dg_neg = 0, ddg_pos = 0, ddg_neg = 0;
  for (int i = -f.feature_radius; i <= f.feature_radius; ++i) {
    float x = float(i);
    float g = std::exp(-(x * x) / (2.f * sd * sd));
    float dg = -x * g;
    float ddg = (x * x / (sd * sd) - 1.f) * g;
    sum_g += g;
    (dg > 0 ? dg_pos : dg_neg) += std::fabs(dg);
    (ddg > 0 ? ddg_pos : ddg_neg) += std::fabs(ddg);
    f.g.push_back(g);
    f.dg.push_back(dg);
    f.ddg.push_back(ddg);
  }
  for (size_t i = 0; i < f.g.size(); ++i) {
    f.g[i] /= sum_g;
    f.dg[i] /= f.dg[i] > 0 ? dg_pos : dg_neg;
    f.ddg[i] /= f.ddg[i] > 0 ? ddg_pos : ddg_neg;
  }
  return f;
}

// ---- Filters in registers -----------------------------------------------------------------------
//
// Each filtered value is one chain of multiply-adds over its taps in order: w_0 x_0, then
// w_k x_k + acc (fused where the build has FMA; the baseline build rounds the product separately).
// Every column of every FMA build computes this same chain, so the AVX2 and AVX-512 builds give the
// same bits, and so did the row sweeps this replaced. A chain stays in a register for all its taps:
// a block of B vectors of columns is filtered by C filters at once (C x B = 8 accumulators), so
// each vector loaded feeds C multiply-adds and an accumulator is stored once per block rather than
// loaded and stored every four taps, and the vertical pass reads the ring rows of a plane once for
// all the filters on it (the Y plane: its CSF and the three feature filters) rather than once per
// filter. Blocks run past the end of a row into the buffers' slack (kSlack floats), so there is no
// remainder loop; what lands in the slack is never read as a result.

template <class Isa>
using FloatsOf = typename detail::Vector<float, Isa::float_lanes>::type;

template <class Isa>
[[gnu::always_inline]] inline FloatsOf<Isa> splat(float x) {
  FloatsOf<Isa> v;
#pragma GCC unroll 16
  for (int l = 0; l < Isa::float_lanes; ++l) v[l] = x;
  return v;
}

// w * x + a per lane, fused (one rounding) where the build has FMA: explicitly, since detail.h
// turns off the compiler's contraction, so every lane and column rounds alike.
template <class Isa, class V>
[[gnu::always_inline]] inline V madd_v(V w, V x, V a) {
  if constexpr (Isa::fma) {
    V r;
#pragma GCC unroll 16
    for (int l = 0; l < Isa::float_lanes; ++l) r[l] = __builtin_fmaf(w[l], x[l], a[l]);
    return r;
  } else {
    return w * x + a;
  }
}

// Accumulators per block: eight chains in flight hide the multiply-add latency (four cycles, two
// issued a cycle).
constexpr int kChains = 8;
// Floats a block may run past the end of a buffer row: 8 vectors of 16.
constexpr int kSlack = 128;

// Vertical: out[c][j] = sum_t w[c][t] rows[pad - radius[c] + t][j], t = 0 .. 2 radius[c], for
// j in [0, count) (and on into the slack). rows: the 2 pad + 1 input rows around the output row.
template <class Isa, int C>
[[gnu::always_inline]] inline void vertical_bank(const float* const* rows, int pad,
                                                 const float* const* w, const int* radius,
                                                 float* const* out, int count) {
  using V = FloatsOf<Isa>;
  constexpr int L = Isa::float_lanes, B = kChains / C;
  static_assert(B * L <= kSlack, "a block must fit in the slack");
  for (int j = 0; j < count; j += B * L) {
    V acc[C][B] = {};  // (every chain starts at its first tap: no value is read)
    for (int k = 0; k <= 2 * pad; ++k) {
      V x[B];
#pragma GCC unroll 8
      for (int b = 0; b < B; ++b) x[b] = detail::load<V>(rows[k] + j + b * L);
#pragma GCC unroll 4
      for (int c = 0; c < C; ++c) {
        const int t = k - (pad - radius[c]);
        if (t < 0 || t > 2 * radius[c]) continue;
        const V wt = splat<Isa>(w[c][t]);
        if (t == 0) {
#pragma GCC unroll 8
          for (int b = 0; b < B; ++b) acc[c][b] = wt * x[b];
        } else {
#pragma GCC unroll 8
          for (int b = 0; b < B; ++b) acc[c][b] = madd_v<Isa>(wt, x[b], acc[c][b]);
        }
      }
    }
#pragma GCC unroll 4
    for (int c = 0; c < C; ++c)
#pragma GCC unroll 8
      for (int b = 0; b < B; ++b) detail::store(out[c] + j + b * L, acc[c][b]);
  }
}

// Horizontal: out[c][j] (=|+=) sum_t w[c][t] in[c][j + t], t = 0 .. taps - 1, for j in [0, n) (and
// on into the slack); `in` already points at the first tap of column 0. Accumulate continues the
// chain already in out (Cz's second Gaussian after its first).
template <class Isa, int C, bool Accumulate>
[[gnu::always_inline]] inline void horizontal_bank(const float* const* in, const float* const* w,
                                                   int taps, float* const* out, int n) {
  using V = FloatsOf<Isa>;
  constexpr int L = Isa::float_lanes, B = kChains / C;
  static_assert(B * L <= kSlack, "a block must fit in the slack");
  for (int j = 0; j < n; j += B * L) {
    V acc[C][B] = {};  // (every chain starts at its first tap: no value is read)
    if constexpr (Accumulate) {
#pragma GCC unroll 4
      for (int c = 0; c < C; ++c)
#pragma GCC unroll 8
        for (int b = 0; b < B; ++b) acc[c][b] = detail::load<V>(out[c] + j + b * L);
    }
    for (int t = 0; t < taps; ++t) {
#pragma GCC unroll 4
      for (int c = 0; c < C; ++c) {
        const V wt = splat<Isa>(w[c][t]);
        if (!Accumulate && t == 0) {
#pragma GCC unroll 8
          for (int b = 0; b < B; ++b) acc[c][b] = wt * detail::load<V>(in[c] + j + t + b * L);
        } else {
#pragma GCC unroll 8
          for (int b = 0; b < B; ++b)
            acc[c][b] = madd_v<Isa>(wt, detail::load<V>(in[c] + j + t + b * L), acc[c][b]);
        }
      }
    }
#pragma GCC unroll 4
    for (int c = 0; c < C; ++c)
#pragma GCC unroll 8
      for (int b = 0; b < B; ++b) detail::store(out[c] + j + b * L, acc[c][b]);
  }
}

// ---- Colour conversion --------------------------------------------------------------------------
// From interleaved pixels (stride S: 1 grey, 3 RGB, 4 RGBA) to YCxCz planes.

template <int S>
[[gnu::always_inline]] inline void ldr_body(const float* px, int n, float* yy, float* cx,
                                            float* cz) {
  // sRGB decode (IEC 61966-2-1), clamp to [0, 1] as the reference tool does for LDR input.
  // One loop per channel into the output planes, then the colour matrix in place: a loop with one
  // power live rather than three keeps its constants in registers on AVX2 (16 of them).
  float* const linear[3] = {yy, cx, cz};
  constexpr int channels = S == 1 ? 1 : 3;
  for (int c = 0; c < channels; ++c) {
    float* __restrict out = linear[c];
    for (int i = 0; i < n; ++i) out[i] = clamp01(detail::srgb_decode_fast(px[i * S + c]));
  }
  float* __restrict y_plane = yy;
  float* __restrict cx_plane = cx;
  float* __restrict cz_plane = cz;
  for (int i = 0; i < n; ++i) {
    const float r = y_plane[i];
    if constexpr (channels == 1)
      rgb_to_ycxcz(r, r, r, y_plane[i], cx_plane[i], cz_plane[i]);
    else
      rgb_to_ycxcz(r, cx_plane[i], cz_plane[i], y_plane[i], cx_plane[i], cz_plane[i]);
  }
}

// Radiance scaled by 2^exposure, tone mapped, clamped, to YCxCz (EG 2021).
template <int S>
[[gnu::always_inline]] inline void hdr_body(const float* px, int n, float scale, Tonemapper tm,
                                            float* yy, float* cx, float* cz) {
  constexpr int g = S == 1 ? 0 : 1, b = S == 1 ? 0 : 2;
  if (tm == Tonemapper::reinhard) {
    for (int i = 0; i < n; ++i) {
      const float rr = px[i * S] * scale, gg = px[i * S + g] * scale, bb = px[i * S + b] * scale;
      const float k = 1.f / (1.f + luminance(rr, gg, bb));
      rgb_to_ycxcz(clamp01(rr * k), clamp01(gg * k), clamp01(bb * k), yy[i], cx[i], cz[i]);
    }
    return;
  }
  const float* c = tone_curve(tm);
  const float c0 = c[0], c1 = c[1], c2 = c[2], c3 = c[3], c4 = c[4], c5 = c[5];
  auto curve = [=](float v) {
    return clamp01((v * v * c0 + v * c1 + c2) / (v * v * c3 + v * c4 + c5));
  };
  for (int i = 0; i < n; ++i)
    rgb_to_ycxcz(curve(px[i * S] * scale), curve(px[i * S + g] * scale),
                 curve(px[i * S + b] * scale), yy[i], cx[i], cz[i]);
}

// ---- The fused pass -----------------------------------------------------------------------------

struct FlipPass {
  int width = 0, height = 0;
  const io::Image* images[2] = {};  // reference, test
  bool hdr = false;
  float exposure_scale = 1;  // HDR: 2^exposure
  Tonemapper tonemapper = Tonemapper::aces;
  const Filters* filters = nullptr;
  float cmax = 0, pccmax = 0;
  // width * height, zero before the first pass; each pass keeps the larger error per pixel, which
  // is HDR-FLIP's maximum over exposures (EG 2021).
  float* error = nullptr;
  // Per-thread scratch, kept across tiles and exposures so large buffers are allocated once.
  tbb::enumerable_thread_specific<std::vector<float>>* scratch = nullptr;
};

// Pixels [c0, c0 + n) of row y of image img, converted to YCxCz.
[[gnu::always_inline]] inline void convert_span(const FlipPass& p, int img, int y, int c0, int n,
                                                float* yy, float* cx, float* cz) {
  const io::Image& image = *p.images[img];
  const int stride = image.channels;
  const float* px =
      image.pixels.data() + (size_t(y) * size_t(image.width) + size_t(c0)) * size_t(stride);
  if (!p.hdr) {
    if (stride == 3)
      ldr_body<3>(px, n, yy, cx, cz);
    else if (stride == 4)
      ldr_body<4>(px, n, yy, cx, cz);
    else
      ldr_body<1>(px, n, yy, cx, cz);
  } else {
    if (stride == 3)
      hdr_body<3>(px, n, p.exposure_scale, p.tonemapper, yy, cx, cz);
    else if (stride == 4)
      hdr_body<4>(px, n, p.exposure_scale, p.tonemapper, yy, cx, cz);
    else
      hdr_body<1>(px, n, p.exposure_scale, p.tonemapper, yy, cx, cz);
  }
}

// The per-pixel part of FLIP for one row, from the filtered values of reference (r) and test (t):
// {Y, Cx, Cz, dx, dy, ddx, ddy}, the first three overwritten. Keeps the larger of the new error and
// out[j].
[[gnu::always_inline]] inline void pixel_errors(int n, float* const* r, float* const* t, float cmax,
                                                float pccmax, float* __restrict out) {
  // Each image's filtered YCxCz to Hunt-adjusted Lab in place, a loop of its own: fewer values live
  // at once than in one loop over everything, so AVX2's 16 registers hold them.
  for (float* const* planes : {r, t}) {
    float* __restrict l = planes[0];
    float* __restrict a = planes[1];
    float* __restrict b = planes[2];
    for (int j = 0; j < n; ++j) ycxcz_to_hunt_lab(l[j], a[j], b[j], l[j], a[j], b[j]);
  }
  const float* __restrict ry = r[0];
  const float* __restrict rcx = r[1];
  const float* __restrict rcz = r[2];
  const float* __restrict rdx = r[3];
  const float* __restrict rdy = r[4];
  const float* __restrict rddx = r[5];
  const float* __restrict rddy = r[6];
  const float* __restrict ty = t[0];
  const float* __restrict tcx = t[1];
  const float* __restrict tcz = t[2];
  const float* __restrict tdx = t[3];
  const float* __restrict tdy = t[4];
  const float* __restrict tddx = t[5];
  const float* __restrict tddy = t[6];
  const float low_slope = kPt / pccmax, high_slope = (1.f - kPt) / (cmax - pccmax);
  // The feature filters ran on Y in [0, 100]; the reference runs them on (Y + 16) / 116. Every
  // feature response has a derivative along one axis, which cancels the offset, so only the scale
  // remains; with FLIP's normalisation of the difference by sqrt(2):
  const float feature_scale = 0.70710678f / 116.f;
  static_assert(kQf == 0.5f, "the feature exponent is applied as a square root");
  for (int j = 0; j < n; ++j) {
    // Colour difference (HPG 2020, colour pipeline): HyAB of the Hunt-adjusted Lab values, raised
    // to q_c, remapped to [0, 1] with p_c * cmax going to p_t.
    const float l1 = ry[j], a1 = rcx[j], b1 = rcz[j], l2 = ty[j], a2 = tcx[j], b2 = tcz[j];
    const float da = a1 - a2, db = b1 - b2;
    float colour = fast_pow(abs_f(l1 - l2) + sqrt_f(da * da + db * db), kQc);
    colour = colour < pccmax ? colour * low_slope : kPt + (colour - pccmax) * high_slope;
    // Feature difference (feature pipeline): the larger change of edge or point strength, raised to
    // q_f = 1/2.
    const float edge_r = sqrt_f(rdx[j] * rdx[j] + rdy[j] * rdy[j]);
    const float edge_t = sqrt_f(tdx[j] * tdx[j] + tdy[j] * tdy[j]);
    const float point_r = sqrt_f(rddx[j] * rddx[j] + rddy[j] * rddy[j]);
    const float point_t = sqrt_f(tddx[j] * tddx[j] + tddy[j] * tddy[j]);
    const float feature =
        sqrt_f(feature_scale * max_f(abs_f(edge_r - edge_t), abs_f(point_r - point_t)));
    // Final error: features amplify the colour error.
    const float e = fast_pow(colour, 1.f - feature);
    out[j] = max_f(out[j], e);
  }
}

// FLIP error of the rows [y0, y1) and columns [x0, x1).
//
// The input rows the vertical taps reach are converted to YCxCz as the tile moves down, into a ring
// of 2 * pad + 1 rows per plane, so no image-sized intermediate is written or read back.
struct FlipTile {
  template <class Isa>
  [[gnu::always_inline]] static void run(const FlipPass* pass, int y0, int y1, int x0, int x1);
};

template <class Isa>
inline void FlipTile::run(const FlipPass* pass, int y0, int y1, int x0, int x1) {
  const FlipPass& p = *pass;
  const Filters& f = *p.filters;
  const int rs = f.spatial_radius, rf = f.feature_radius, pad = rs > rf ? rs : rf;
  const int ts = 2 * rs + 1, tf = 2 * rf + 1, ring = 2 * pad + 1;
  const int w = p.width, h = p.height;
  const int n = x1 - x0, pn = n + 2 * pad;
  // The vertical pass covers the columns the horizontal taps reach that exist; the padded row's
  // entry i is column x0 - pad + i, and entries left or right of the image repeat its edge.
  const int c0 = x0 - pad > 0 ? x0 - pad : 0, c1 = x1 + pad < w ? x1 + pad : w;
  const int lead = c0 - (x0 - pad), count = c1 - c0;

  // Scratch: ring [2 images][3 planes][ring rows][count], vertical rows [7][pn], outputs [14][n],
  // each row followed by the slack the filters' blocks run into.
  auto with_slack = [](int floats) { return size_t(floats + kSlack + 15) / 16 * 16; };
  const size_t ring_stride = with_slack(count), v_stride = with_slack(pn), o_stride = with_slack(n);
  const size_t ring_floats = size_t(6) * size_t(ring) * ring_stride;
  std::vector<float>& scratch = p.scratch->local();
  const size_t need = ring_floats + size_t(7) * v_stride + size_t(14) * o_stride;
  if (scratch.size() < need) scratch.resize(need);
  // (Lambdas here stay trivial: a lambda is its own function, compiled for the baseline target
  // unless inlined, so the conversion loops are called directly.)
  auto ring_row = [&](int img, int plane, int y) {  // y: an image row, already clamped
    return scratch.data() +
           (size_t(img * 3 + plane) * size_t(ring) + size_t(y % ring)) * ring_stride;
  };
  const float* rows[512];  // taps; make_filters keeps 2 * pad + 1 below this
  auto vertical_rows = [&](int img, int plane, int y) {
    for (int k = 0; k <= 2 * pad; ++k) {
      int yy = y + k - pad;
      yy = yy < 0 ? 0 : (yy > h - 1 ? h - 1 : yy);
      rows[k] = ring_row(img, plane, yy);
    }
  };
  const float cmax = p.cmax, pccmax = p.pccmax;
  float* v[7];
  for (int q = 0; q < 7; ++q) v[q] = scratch.data() + ring_floats + size_t(q) * v_stride;
  float* o[2][7];
  for (int img = 0; img < 2; ++img)
    for (int q = 0; q < 7; ++q)
      o[img][q] =
          scratch.data() + ring_floats + size_t(7) * v_stride + size_t(img * 7 + q) * o_stride;

  // Filter banks: the Y plane feeds the CSF and the three feature filters, Cz its two Gaussians.
  const float* const y_weights[4] = {f.y.data(), f.g.data(), f.dg.data(), f.ddg.data()};
  const int y_radii[4] = {rs, rf, rf, rf};
  const float* const cx_weights[1] = {f.cx.data()};
  const float* const cz_weights[2] = {f.cz1.data(), f.cz2.data()};
  const int cx_radii[1] = {rs}, cz_radii[2] = {rs, rs};
  const float* const y_horizontal[1] = {f.y.data()};
  const float* const cx_horizontal[1] = {f.cx.data()};
  const float* const cz1_horizontal[1] = {f.cz1.data()};
  const float* const cz2_horizontal[1] = {f.cz2.data()};
  const float* const derivatives[2] = {f.dg.data(), f.ddg.data()};
  const float* const gaussians[2] = {f.g.data(), f.g.data()};
  const int spatial_offset = pad - rs, feature_offset = pad - rf;

  // Output row y needs input rows y - pad .. y + pad (clamped): all of them for the first row, then
  // one more per row, overwriting the ring slot of the row no longer needed.
  int next = y0 - pad > 0 ? y0 - pad : 0;
  for (int y = y0; y < y1; ++y) {
    for (const int last = y + pad < h - 1 ? y + pad : h - 1; next <= last; ++next)
      for (int img = 0; img < 2; ++img)
        convert_span(p, img, next, c0, count, ring_row(img, 0, next), ring_row(img, 1, next),
                     ring_row(img, 2, next));
    for (int img = 0; img < 2; ++img) {
      // Vertical: v = {Y, Cx, Cz (1st Gaussian), Cz (2nd), G Y, G' Y, G'' Y}.
      {
        vertical_rows(img, 0, y);
        float* const out[4] = {v[0] + lead, v[4] + lead, v[5] + lead, v[6] + lead};
        vertical_bank<Isa, 4>(rows, pad, y_weights, y_radii, out, count);
      }
      {
        vertical_rows(img, 1, y);
        float* const out[1] = {v[1] + lead};
        vertical_bank<Isa, 1>(rows, pad, cx_weights, cx_radii, out, count);
      }
      {
        vertical_rows(img, 2, y);
        float* const out[2] = {v[2] + lead, v[3] + lead};
        vertical_bank<Isa, 2>(rows, pad, cz_weights, cz_radii, out, count);
      }
      for (int q = 0; q < 7; ++q) {
        for (int j = 0; j < lead; ++j) v[q][j] = v[q][lead];
        for (int j = lead + count; j < pn; ++j) v[q][j] = v[q][lead + count - 1];
      }
      // Horizontal: o = {Y, Cx, Cz, dx, dy, ddx, ddy}.
      float* const* out = o[img];
      {
        const float* const in[1] = {v[0] + spatial_offset};
        horizontal_bank<Isa, 1, false>(in, y_horizontal, ts, &out[0], n);
      }
      {
        const float* const in[1] = {v[1] + spatial_offset};
        horizontal_bank<Isa, 1, false>(in, cx_horizontal, ts, &out[1], n);
      }
      {
        const float* const first[1] = {v[2] + spatial_offset};
        horizontal_bank<Isa, 1, false>(first, cz1_horizontal, ts, &out[2], n);
        const float* const second[1] = {v[3] + spatial_offset};
        horizontal_bank<Isa, 1, true>(second, cz2_horizontal, ts, &out[2], n);
      }
      {
        const float* const in[2] = {v[4] + feature_offset, v[4] + feature_offset};
        float* const d[2] = {out[3], out[5]};
        horizontal_bank<Isa, 2, false>(in, derivatives, tf, d, n);
      }
      {
        const float* const in[2] = {v[5] + feature_offset, v[6] + feature_offset};
        float* const d[2] = {out[4], out[6]};
        horizontal_bank<Isa, 2, false>(in, gaussians, tf, d, n);
      }
    }
    pixel_errors(n, o[0], o[1], cmax, pccmax, p.error + size_t(y) * size_t(w) + size_t(x0));
  }
}

void run_pass(const FlipPass& pass) {
  // Tiles of a fixed size, one task each. Every tile converts 2 * pad halo rows and columns beyond
  // its own and filters its halo columns vertically, so tiles must be large: 96 x 512 pixels spend
  // 1.26x the conversions of a whole image, where blocked_range2d's halving (grain 64 x 256) left
  // 34 x 240 tiles at 1080p, 1.72x. A tile's ring (6 planes x 21 rows x 532 floats, plus the
  // filters' slack: 660) still fits in the core's L2 cache.
  constexpr int kTileRows = 96, kTileCols = 512;
  const int across = (pass.width + kTileCols - 1) / kTileCols;
  const int down = (pass.height + kTileRows - 1) / kTileRows;
  tbb::parallel_for(0, across * down, [&](int tile) {
    const int y0 = tile / across * kTileRows, x0 = tile % across * kTileCols;
    detail::dispatch<FlipTile>(&pass, y0, std::min(y0 + kTileRows, pass.height), x0,
                               std::min(x0 + kTileCols, pass.width));
  });
}

// EG 2021's automatic exposure range (as the reference tool's computeExposures): the start exposure
// maps the largest reference luminance, the stop exposure the median luminance, to the tone curve's
// 0.85.
HdrExposures automatic_exposures(const io::Image& reference, Tonemapper tm) {
  const float* c = tone_curve(tm);
  const float t = 0.85f;
  const float a = c[0] - t * c[3], b = c[1] - t * c[4], k = c[2] - t * c[5];
  // The larger root of a x^2 + b x + k = 0: the radiance the curve maps to t.
  float x_max;
  if (a == 0.f) {
    x_max = -k / b;
  } else {
    const float d1 = -0.5f * (b / a);
    x_max = d1 + std::sqrt(d1 * d1 - k / a);
  }
  // Luminances, their maximum and smallest positive value, and the one at rank n / 2 (the reference
  // tool, from v1.4, takes that element rather than the mean of the middle two). Rank n / 2 is
  // found without sorting: a histogram over the top 16 bits of an order-preserving key, then
  // nth_element inside the one bucket that holds the rank.
  const size_t n = reference.pixel_count(), stride = size_t(reference.channels);
  const size_t gi = reference.channels == 1 ? 0 : 1, bi = reference.channels == 1 ? 0 : 2;
  auto lum_at = [&](size_t i) {
    const float* px = &reference.pixels[i * stride];
    return luminance(px[0], px[gi], px[bi]);
  };
  auto bucket = [](float v) {
    const uint32_t bits = __builtin_bit_cast(uint32_t, v);
    return ((bits & 0x80000000u) ? ~bits : (bits | 0x80000000u)) >> 16;
  };
  std::vector<uint32_t> counts(size_t(1) << 16, 0);
  float y_max = -std::numeric_limits<float>::infinity();
  float y_min_positive = std::numeric_limits<float>::infinity();
  for (size_t i = 0; i < n; ++i) {
    const float l = lum_at(i);
    ++counts[bucket(l)];
    y_max = l > y_max ? l : y_max;
    if (l > 0.f && l < y_min_positive) y_min_positive = l;
  }
  const size_t mid = n / 2;
  size_t below = 0, median_bucket = 0;
  while (below + counts[median_bucket] <= mid) below += counts[median_bucket++];
  std::vector<float> in_bucket;
  in_bucket.reserve(counts[median_bucket]);
  for (size_t i = 0; i < n; ++i) {
    const float l = lum_at(i);
    if (bucket(l) == median_bucket) in_bucket.push_back(l);
  }
  const auto nth = in_bucket.begin() + std::ptrdiff_t(mid - below);
  std::nth_element(in_bucket.begin(), nth, in_bucket.end());
  float y_median = *nth;
  // Deviation: the tool divides by zero when more than half the image (or all of it) is black; we
  // fall back to the smallest positive luminance, and to exposure 0 for an all-black reference.
  if (!(y_max > 0.f)) return {0.0, 0.0, 2};
  if (!(y_median > 0.f)) y_median = y_min_positive;
  HdrExposures e;
  e.start = std::log2(x_max / y_max);
  e.stop = std::log2(x_max / y_median);
  e.count = int(std::max(2.0f, std::ceil(float(e.stop) - float(e.start))));
  return e;
}

// Weighted quantiles of non-negative values as the reference tool pools them: the smallest value
// v with sum(values <= v, counted in sorted order) > p * sum(all values). Rather than sorting
// everything, values are bucketed by their top float bits (ordered like the values), the bucket
// where the running sum crosses p * total is found, and only that bucket is sorted.
std::array<double, 3> weighted_quantiles(const float* v, size_t n, size_t stride, double total,
                                         const std::array<double, 3>& p) {
  std::array<double, 3> result{0, 0, 0};
  if (!(total > 0)) return result;  // all zero: no running sum exceeds 0
  constexpr int kShift = 17;        // 2^15 buckets over the positive floats, ~1.6% wide
  constexpr size_t kBuckets = size_t(1) << (31 - kShift);
  std::vector<double> sums(kBuckets, 0.0);
  auto bucket = [](float x) { return size_t(__builtin_bit_cast(uint32_t, x) >> kShift); };
  for (size_t i = 0; i < n; ++i) sums[bucket(v[i * stride])] += double(v[i * stride]);
  for (int q = 0; q < 3; ++q) {
    const double target = p[size_t(q)] * total;
    double below = 0;
    size_t b = 0;
    while (b < kBuckets && below + sums[b] <= target) below += sums[b++];
    if (b == kBuckets) {  // rounding left the target above the total: the largest value
      float m = 0;
      for (size_t i = 0; i < n; ++i) m = std::max(m, v[i * stride]);
      result[size_t(q)] = m;
      continue;
    }
    std::vector<float> in_bucket;
    for (size_t i = 0; i < n; ++i)
      if (bucket(v[i * stride]) == b) in_bucket.push_back(v[i * stride]);
    std::sort(in_bucket.begin(), in_bucket.end());
    double running = below;
    result[size_t(q)] = in_bucket.back();
    for (float x : in_bucket) {
      running += x;
      if (running > target) {
        result[size_t(q)] = x;
        break;
      }
    }
  }
  return result;
}

}  // namespace

FlipStats pool_flip(const io::Image& error_map) {
  if (error_map.pixel_count() == 0 || error_map.channels < 1)
    throw InputError("FLIP pooling: the error map is empty");
  const size_t n = error_map.pixel_count(), stride = size_t(error_map.channels);
  const float* v = error_map.pixels.data();
  FlipStats s;
  double sum = 0;
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  bool negative = false;
  for (size_t i = 0; i < n; ++i) {
    const float x = v[i * stride];
    if (!std::isfinite(x)) throw InputError("FLIP pooling: the error map has non-finite values");
    sum += x;
    lo = std::min(lo, x);
    hi = std::max(hi, x);
    negative |= x < 0.f;
  }
  if (negative) throw InputError("FLIP pooling: the error map has negative values");
  s.mean = sum / double(n);
  s.min = lo;
  s.max = hi;
  auto q = weighted_quantiles(v, n, stride, sum, {0.25, 0.5, 0.75});
  s.q1 = q[0];
  s.weighted_median = q[1];
  s.q3 = q[2];
  return s;
}

FlipResult flip(const io::Image& reference, const io::Image& test, const FlipOptions& options) {
  detail::check_pair(reference, test, "FLIP");
  if (!(options.pixels_per_degree > 0.0) || !std::isfinite(options.pixels_per_degree))
    throw InputError(
        fmt::format("FLIP: pixels per degree must be positive, not {}", options.pixels_per_degree));
  const int w = reference.width, h = reference.height;
  const Filters filters = make_filters(float(options.pixels_per_degree));
  const float cmax = max_colour_distance();

  // The ring of rows in flip_tile holds one row per filter tap.
  if (2 * std::max(filters.spatial_radius, filters.feature_radius) + 1 > 511)
    throw InputError(fmt::format("FLIP: {} pixels per degree needs filters wider than 511 taps",
                                 options.pixels_per_degree));

  FlipResult result;
  result.error_map = io::Image(w, h, 1, /*is_linear=*/false);
  tbb::enumerable_thread_specific<std::vector<float>> scratch;
  FlipPass pass;
  pass.width = w;
  pass.height = h;
  pass.images[0] = &reference;
  pass.images[1] = &test;
  pass.hdr = reference.linear;
  pass.tonemapper = options.tonemapper;
  pass.filters = &filters;
  pass.cmax = cmax;
  pass.pccmax = kPc * cmax;
  pass.error = result.error_map.pixels.data();
  pass.scratch = &scratch;

  if (!reference.linear) {
    run_pass(pass);
  } else {
    HdrExposures e;
    if (!options.start_exposure || !options.stop_exposure)
      e = automatic_exposures(reference, options.tonemapper);
    if (options.start_exposure) e.start = *options.start_exposure;
    if (options.stop_exposure) e.stop = *options.stop_exposure;
    if (e.start > e.stop)
      throw InputError(fmt::format("FLIP: the start exposure ({}) is above the stop exposure ({})",
                                   e.start, e.stop));
    e.count = options.num_exposures.value_or(
        int(std::max(2.0f, std::ceil(float(e.stop) - float(e.start)))));
    if (e.count < 1)
      throw InputError(
          fmt::format("FLIP: the number of exposures must be 1 or more, not {}", e.count));
    // EG 2021: LDR-FLIP at evenly spaced exposures, the per-pixel maximum kept.
    const float start = float(e.start), stop = float(e.stop);
    const float step = e.count > 1 ? (stop - start) / float(e.count - 1) : 0.f;
    for (int i = 0; i < e.count; ++i) {
      pass.exposure_scale = std::pow(2.0f, start + float(i) * step);
      run_pass(pass);
    }
    result.exposures = e;
  }
  result.stats = pool_flip(result.error_map);
  return result;
}

}  // namespace pb::metrics
