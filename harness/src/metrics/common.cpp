// Input checks and planar copies shared by the metrics (see detail.h).
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <cmath>
#include <string>

#include "metrics/detail.h"
#include "metrics/metrics.h"
#include "photonbench/error.h"

namespace pb::metrics {

namespace {

VectorPath widest_path() {
#if PB_METRICS_LEVELS
  if (__builtin_cpu_supports("x86-64-v4")) return VectorPath::avx512;
  if (__builtin_cpu_supports("x86-64-v3")) return VectorPath::avx2;
#endif
  return VectorPath::baseline;
}

std::atomic<VectorPath>& path_in_use() {
  static std::atomic<VectorPath> path{widest_path()};
  return path;
}

}  // namespace

const char* to_string(VectorPath path) {
  switch (path) {
    case VectorPath::baseline:
      return "baseline (SSE2)";
    case VectorPath::avx2:
      return "AVX2+FMA";
    case VectorPath::avx512:
      return "AVX-512";
  }
  return "?";
}

bool cpu_runs(VectorPath path) { return int(path) <= int(widest_path()); }

VectorPath vector_path() { return path_in_use().load(std::memory_order_relaxed); }

void use_vector_path(VectorPath path) {
  if (!cpu_runs(path))
    throw InputError(
        fmt::format("metrics: this CPU cannot run the {} build (the widest it runs: {})",
                    to_string(path), to_string(widest_path())));
  path_in_use().store(path, std::memory_order_relaxed);
}

namespace detail {
VectorPath active_path() { return vector_path(); }
}  // namespace detail

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
struct AllFinite {
  template <class Isa>
  [[gnu::always_inline]] static bool run(const float* v, size_t n) {
    uint32_t bad = 0;
    for (size_t i = 0; i < n; ++i)
      bad |= uint32_t((__builtin_bit_cast(uint32_t, v[i]) & 0x7F800000u) == 0x7F800000u);
    return bad == 0;
  }
};

void check_image(const io::Image& image, const char* role, std::string_view metric) {
  if (image.width <= 0 || image.height <= 0)
    throw InputError(fmt::format("{}: the {} image is empty", metric, role));
  if (image.channels != 1 && image.channels != 3 && image.channels != 4)
    throw InputError(fmt::format("{}: the {} image has {} channels (expected 1, 3 or 4)", metric,
                                 role, image.channels));
  if (image.pixels.size() != image.pixel_count() * size_t(image.channels))
    throw InputError(fmt::format("{}: the {} image holds {} values, not {}x{}x{}", metric, role,
                                 image.pixels.size(), image.width, image.height, image.channels));
  if (dispatch<AllFinite>(image.pixels.data(), image.pixels.size())) return;
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

// Isa::lanes values at a time in GCC vectors, the same operations per lane as code_or_minus_one,
// and the scalar loop for the rest of the row (so the same bits): the scalar loop alone does not
// vectorise (the strided loads and the selects leave it branching).
struct LdrDisplayRow {
  template <class Isa, size_t Stride>
  [[gnu::always_inline]] static void row(const float* in, size_t n, double* out) {
    constexpr int kLanes = Isa::lanes;
    using Floats = typename Vector<float, kLanes>::type;
    using Ints = typename Vector<int32_t, kLanes>::type;
    using Longs = typename Vector<int64_t, kLanes>::type;
    using Doubles = DoublesOf<Isa>;
    size_t i = 0;
    for (; i + kLanes <= n; i += kLanes) {
      Floats v;
      for (int l = 0; l < kLanes; ++l) v[l] = in[(i + size_t(l)) * Stride];
      const Floats scaled255 = v * 255.f;
      const Floats below = 255.f < scaled255 ? Floats{} + 255.f : scaled255;  // min_f
      const Floats scaled = below < 0.f ? Floats{} : below;                   // max_f(below, 0)
      const Ints k = __builtin_convertvector(scaled + 0.5f, Ints);
      const Floats off = scaled255 - __builtin_convertvector(k, Floats);
      const Ints is_code = (off < 0.f ? -off : off) < 2e-5f;  // -1 where v is a code
      const Doubles code = __builtin_convertvector(k, Doubles) / 255.0;
      const Doubles value = __builtin_convertvector(v, Doubles);
      store(out + i, __builtin_convertvector(is_code, Longs) != 0 ? code : value);
    }
    for (; i < n; ++i) {
      const float v = in[i * Stride];
      const int k = code_or_minus_one(v);
      out[i] = k >= 0 ? double(k) / 255.0 : double(v);  // division, as numpy does
    }
  }
  // The stride (channels) as a constant, so the strided loads become shuffles.
  template <class Isa>
  [[gnu::always_inline]] static void run(const float* in, size_t stride, size_t n, double* out) {
    if (stride == 3)
      row<Isa, 3>(in, n, out);
    else if (stride == 4)
      row<Isa, 4>(in, n, out);
    else
      row<Isa, 1>(in, n, out);
  }
};

// 8-bit codes through the table; returns false if some value was not one (left as -1).
struct LdrLinearRow {
  template <class Isa>
  [[gnu::always_inline]] static bool run(const float* in, size_t stride, size_t n,
                                         const double* table, double* out) {
    int all_codes = 1;
    for (size_t i = 0; i < n; ++i) {
      const int k = code_or_minus_one(in[i * stride]);
      all_codes &= k >= 0;
      out[i] = k >= 0 ? table[k > 0 ? k : 0] : -1.0;
    }
    return all_codes != 0;
  }
};

// The stride (channels) as a constant, so the compiler vectorises the strided loads.
struct HdrDisplayRow {
  template <size_t Stride>
  [[gnu::always_inline]] static void row(const float* in, size_t n, double* out) {
    for (size_t i = 0; i < n; ++i) {
      const float c = clamp01(in[i * Stride]);
      out[i] =
          c <= 0.0031308f ? 12.92 * double(c) : 1.055 * double(fast_pow(c, 1.f / 2.4f)) - 0.055;
    }
  }
  template <class Isa>
  [[gnu::always_inline]] static void run(const float* in, size_t stride, size_t n, double* out) {
    if (stride == 3)
      row<3>(in, n, out);
    else if (stride == 4)
      row<4>(in, n, out);
    else
      row<1>(in, n, out);
  }
};

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
      dispatch<HdrDisplayRow>(in, stride, n, out);  // clamp to [0, 1], then sRGB encode
    } else {
      for (size_t i = 0; i < n; ++i) out[i] = double(in[i * stride]);
    }
    return;
  }
  if (values == Values::display)
    dispatch<LdrDisplayRow>(in, stride, n, out);
  else if (!dispatch<LdrLinearRow>(in, stride, n, decoded_codes().data(), out))
    for (size_t i = 0; i < n; ++i)  // values that are not 8-bit codes: decode exactly
      if (out[i] < 0.0) out[i] = srgb_decode_exact(std::clamp(double(in[i * stride]), 0.0, 1.0));
}

}  // namespace detail
}  // namespace pb::metrics
