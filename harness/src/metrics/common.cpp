// Input checks and planar copies shared by the metrics (see detail.h).
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <string>

#include "metrics/detail.h"
#include "metrics/metrics.h"
#include "photonbench/error.h"

namespace pb::metrics {

Tonemapper parse_tonemapper(std::string_view name) {
  std::string lower(name);
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  if (lower == "aces") return Tonemapper::aces;
  if (lower == "hable") return Tonemapper::hable;
  if (lower == "reinhard") return Tonemapper::reinhard;
  throw InputError(
      fmt::format("unknown tone mapper '{}' (expected aces, hable or reinhard)", name));
}

const char* to_string(Tonemapper tonemapper) {
  switch (tonemapper) {
    case Tonemapper::aces:
      return "aces";
    case Tonemapper::hable:
      return "hable";
    case Tonemapper::reinhard:
      return "reinhard";
  }
  return "?";
}

namespace detail {
namespace {

const char* encoding(const io::Image& image) {
  return image.linear ? "HDR (linear)" : "LDR (display-encoded)";
}

// True when no value is NaN or infinite (all exponent bits set), as one vectorised pass.
PB_METRICS_KERNEL bool all_finite(const float* v, size_t n) {
  uint32_t bad = 0;
  for (size_t i = 0; i < n; ++i)
    bad |= uint32_t((__builtin_bit_cast(uint32_t, v[i]) & 0x7F800000u) == 0x7F800000u);
  return bad == 0;
}

void check_image(const io::Image& image, const char* role, std::string_view metric) {
  if (image.width <= 0 || image.height <= 0)
    throw InputError(fmt::format("{}: the {} image is empty", metric, role));
  if (image.channels != 1 && image.channels != 3 && image.channels != 4)
    throw InputError(fmt::format("{}: the {} image has {} channels (expected 1, 3 or 4)", metric,
                                 role, image.channels));
  if (image.pixels.size() != image.pixel_count() * size_t(image.channels))
    throw InputError(fmt::format("{}: the {} image holds {} values, not {}x{}x{}", metric, role,
                                 image.pixels.size(), image.width, image.height, image.channels));
  if (all_finite(image.pixels.data(), image.pixels.size())) return;
  auto bad = std::find_if(image.pixels.begin(), image.pixels.end(),
                          [](float v) { return !std::isfinite(v); });
  if (bad != image.pixels.end()) {
    size_t pixel = size_t(bad - image.pixels.begin()) / size_t(image.channels);
    throw InputError(fmt::format("{}: the {} image has a non-finite value ({}) at pixel ({}, {})",
                                 metric, role, *bad, pixel % size_t(image.width),
                                 pixel / size_t(image.width)));
  }
}

double srgb_decode_exact(double v) {
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

const std::array<double, 256>& decoded_codes() {
  static const std::array<double, 256> table = [] {
    std::array<double, 256> t{};
    for (int k = 0; k < 256; ++k) t[size_t(k)] = srgb_decode_exact(k / 255.0);
    return t;
  }();
  return table;
}

// 8-bit LDR files are read as k / 255 in float; this recovers k when the value is one of those
// (for a float-rounded k / 255, |255 v - k| stays below 1.6e-5), else gives -1, so the metrics can
// use k / 255 and the sRGB decoding of k exactly, as tools reading the file as uint8 do.
[[gnu::always_inline]] inline int code_or_minus_one(float v) {
  const float scaled = max_f(min_f(v * 255.f, 255.f), 0.f);
  const int k = int(scaled + 0.5f);
  return abs_f(v * 255.f - float(k)) < 2e-5f ? k : -1;
}

// Eight values at a time in GCC vectors, the same operations per lane as code_or_minus_one and the
// scalar loop for the rest of the row (so the same bits): the scalar loop alone does not vectorise
// (the strided loads and the selects leave it branching).
typedef float Floats8 __attribute__((vector_size(32)));
typedef int32_t Ints8 __attribute__((vector_size(32)));
typedef int64_t Longs8 __attribute__((vector_size(64)));
typedef double Doubles8 __attribute__((vector_size(64)));
typedef double Doubles8At __attribute__((vector_size(64), aligned(8), may_alias));

PB_METRICS_KERNEL void ldr_display_row(const float* in, size_t stride, size_t n, double* out) {
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    Floats8 v;
    for (size_t l = 0; l < 8; ++l) v[l] = in[(i + l) * stride];
    const Floats8 scaled255 = v * 255.f;
    const Floats8 below = 255.f < scaled255 ? Floats8{} + 255.f : scaled255;  // min_f
    const Floats8 scaled = below < 0.f ? Floats8{} : below;                   // max_f(below, 0)
    const Ints8 k = __builtin_convertvector(scaled + 0.5f, Ints8);
    const Floats8 off = scaled255 - __builtin_convertvector(k, Floats8);
    const Ints8 is_code = (off < 0.f ? -off : off) < 2e-5f;  // -1 where v is a code
    const Doubles8 code = __builtin_convertvector(k, Doubles8) / 255.0;
    const Doubles8 value = __builtin_convertvector(v, Doubles8);
    *reinterpret_cast<Doubles8At*>(out + i) =
        __builtin_convertvector(is_code, Longs8) != 0 ? code : value;
  }
  for (; i < n; ++i) {
    const float v = in[i * stride];
    const int k = code_or_minus_one(v);
    out[i] = k >= 0 ? double(k) / 255.0 : double(v);  // division, as numpy does
  }
}

// 8-bit codes through the table; returns false if some value was not one (left as -1).
PB_METRICS_KERNEL bool ldr_linear_row(const float* in, size_t stride, size_t n, const double* table,
                                      double* out) {
  int all_codes = 1;
  for (size_t i = 0; i < n; ++i) {
    const int k = code_or_minus_one(in[i * stride]);
    all_codes &= k >= 0;
    out[i] = k >= 0 ? table[k > 0 ? k : 0] : -1.0;
  }
  return all_codes != 0;
}

PB_METRICS_KERNEL void hdr_display_row(const float* in, size_t stride, size_t n, double* out) {
  for (size_t i = 0; i < n; ++i) {
    const float c = clamp01(in[i * stride]);
    out[i] = c <= 0.0031308f ? 12.92 * double(c) : 1.055 * double(fast_pow(c, 1.f / 2.4f)) - 0.055;
  }
}

}  // namespace

void check_pair(const io::Image& reference, const io::Image& test, std::string_view metric) {
  check_image(reference, "reference", metric);
  check_image(test, "test", metric);
  if (reference.width != test.width || reference.height != test.height)
    throw InputError(fmt::format("{}: the reference is {}x{} but the test is {}x{}", metric,
                                 reference.width, reference.height, test.width, test.height));
  if (reference.linear != test.linear)
    throw InputError(fmt::format("{}: the reference is {} but the test is {}", metric,
                                 encoding(reference), encoding(test)));
}

void convert_row(const io::Image& image, int y, int channel, Values values, double* out) {
  const size_t stride = size_t(image.channels), n = size_t(image.width);
  const float* in =
      image.pixels.data() + size_t(y) * n * stride + size_t(image.channels == 1 ? 0 : channel);
  if (image.linear) {
    if (values == Values::display) {
      hdr_display_row(in, stride, n, out);  // clamp to [0, 1], then sRGB encode
    } else {
      for (size_t i = 0; i < n; ++i) out[i] = double(in[i * stride]);
    }
    return;
  }
  if (values == Values::display)
    ldr_display_row(in, stride, n, out);
  else if (!ldr_linear_row(in, stride, n, decoded_codes().data(), out))
    for (size_t i = 0; i < n; ++i)  // values that are not 8-bit codes: decode exactly
      if (out[i] < 0.0) out[i] = srgb_decode_exact(std::clamp(double(in[i * stride]), 0.0, 1.0));
}

}  // namespace detail
}  // namespace pb::metrics
