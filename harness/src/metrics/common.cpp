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
    case Tonemapper::aces: return "aces";
    case Tonemapper::hable: return "hable";
    case Tonemapper::reinhard: return "reinhard";
  }
  return "?";
}

namespace detail {
namespace {

const char* encoding(const io::Image& image) {
  return image.linear ? "HDR (linear)" : "LDR (display-encoded)";
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
  auto bad = std::find_if(image.pixels.begin(), image.pixels.end(),
                          [](float v) { return !std::isfinite(v); });
  if (bad != image.pixels.end()) {
    size_t pixel = size_t(bad - image.pixels.begin()) / size_t(image.channels);
    throw InputError(fmt::format("{}: the {} image has a non-finite value ({}) at pixel ({}, {})",
                                 metric, role, *bad, pixel % size_t(image.width),
                                 pixel / size_t(image.width)));
  }
}

// 8-bit LDR files are read as k / 255 in float; this recovers k when the value is one of those
// (for a float-rounded k / 255, |255 v - k| stays below 1.6e-5).
inline bool eight_bit_code(float v, int& k) {
  float scaled = v * 255.f;
  k = int(std::lround(scaled));
  return k >= 0 && k <= 255 && std::fabs(scaled - float(k)) < 2e-5f;
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

// One value per colour channel of each pixel, converted by `convert(value)`.
template <typename T, typename Convert>
Planes<T> to_planes(const io::Image& image, Convert convert) {
  Planes<T> planes;
  planes.width = image.width;
  planes.height = image.height;
  const size_t n = image.pixel_count();
  for (auto& plane : planes.c) plane.resize(n);
  const int channels = image.channels;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      const float* px = &image.pixels[i * size_t(channels)];
      for (int c = 0; c < 3; ++c) planes.c[c][i] = convert(px[channels == 1 ? 0 : c]);
    }
  });
  return planes;
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

Planes<float> stored_planes(const io::Image& image) {
  return to_planes<float>(image, [](float v) { return v; });
}

Planes<double> display_planes(const io::Image& image) {
  if (image.linear)
    // Clamp, then the sRGB transfer function (the "display-encoded" HDR values).
    return to_planes<double>(image, [](float v) {
      double c = std::clamp(double(v), 0.0, 1.0);
      return c <= 0.0031308 ? 12.92 * c : 1.055 * double(fast_pow(float(c), 1.f / 2.4f)) - 0.055;
    });
  return to_planes<double>(image, [](float v) {
    int k;
    return eight_bit_code(v, k) ? k / 255.0 : double(v);
  });
}

Planes<double> linear_planes(const io::Image& image) {
  if (image.linear) return to_planes<double>(image, [](float v) { return double(v); });
  const auto& table = decoded_codes();
  return to_planes<double>(image, [&table](float v) {
    int k;
    return eight_bit_code(v, k) ? table[size_t(k)] : srgb_decode_exact(std::clamp(double(v), 0.0, 1.0));
  });
}

}  // namespace detail
}  // namespace pb::metrics
