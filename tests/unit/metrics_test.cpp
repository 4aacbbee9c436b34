// Metrics against their reference implementations (tests/data/metrics/expected.json: the FLIP v1.6
// tool and scikit-image 0.19) and against values worked out by hand.
#include "metrics/metrics.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "io/image.h"
#include "metrics/noise_floor.h"
#include "photonbench/error.h"

namespace pb::metrics {
namespace metrics_test {

const std::filesystem::path kData = std::filesystem::path(PB_TEST_DATA_DIR) / "metrics";

nlohmann::json expected_cases() {
  std::ifstream in(kData / "expected.json");
  return nlohmann::json::parse(in)["cases"];
}

io::Image constant(int w, int h, float r, float g, float b, bool linear) {
  io::Image image(w, h, 3, linear);
  for (size_t i = 0; i < image.pixel_count(); ++i) {
    image.pixels[3 * i] = r;
    image.pixels[3 * i + 1] = g;
    image.pixels[3 * i + 2] = b;
  }
  return image;
}

// A deterministic LDR test card with 8-bit values: gradients, a disc and seeded noise.
io::Image card(int w, int h, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> noise(-12, 12);
  io::Image image(w, h, 3, false);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      int base[3] = {
          255 * x / w, 255 * y / h,
          (x - w / 2) * (x - w / 2) + (y - h / 2) * (y - h / 2) < (w * h) / 16 ? 220 : 40};
      for (int c = 0; c < 3; ++c)
        image.at(x, y, c) = float(std::clamp(base[c] + noise(rng), 0, 255)) / 255.f;
    }
  return image;
}

void expect_flip_stats(const FlipStats& got, const nlohmann::json& want, const std::string& what) {
  constexpr double tol = 1e-4;
  EXPECT_NEAR(got.mean, want["mean"].get<double>(), tol) << what << " mean";
  EXPECT_NEAR(got.weighted_median, want["weighted_median"].get<double>(), tol) << what << " median";
  EXPECT_NEAR(got.q1, want["q1"].get<double>(), tol) << what << " q1";
  EXPECT_NEAR(got.q3, want["q3"].get<double>(), tol) << what << " q3";
  EXPECT_NEAR(got.min, want["min"].get<double>(), tol) << what << " min";
  EXPECT_NEAR(got.max, want["max"].get<double>(), tol) << what << " max";
}

TEST(MetricsConformance, EveryCaseMatchesTheReferenceTools) {
  const nlohmann::json cases = expected_cases();
  ASSERT_EQ(cases.size(), 12u);
  for (const auto& c : cases) {
    const std::string name = c["reference"].get<std::string>();
    SCOPED_TRACE(name);
    const io::Image ref = io::read_image(kData / c["reference"].get<std::string>());
    const io::Image test = io::read_image(kData / c["test"].get<std::string>());
    const bool hdr = c["kind"] == "hdr";
    ASSERT_EQ(ref.linear, hdr);

    const FlipResult f = flip(ref, test);
    expect_flip_stats(f.stats, c["flip"], name);
    ASSERT_EQ(f.error_map.width, ref.width);
    ASSERT_EQ(f.error_map.channels, 1);
    if (hdr) {
      ASSERT_TRUE(f.exposures.has_value());
      EXPECT_NEAR(f.exposures->start, c["flip"]["start_exposure"].get<double>(), 1e-4);
      EXPECT_NEAR(f.exposures->stop, c["flip"]["stop_exposure"].get<double>(), 1e-4);
      EXPECT_EQ(f.exposures->count, c["flip"]["num_exposures"].get<int>());
    } else {
      EXPECT_FALSE(f.exposures.has_value());
    }

    const Scores s = evaluate(ref, test);
    const nlohmann::json& want_ssim = hdr ? c["ssim_display"] : c["ssim"];
    const nlohmann::json& want_psnr = hdr ? c["psnr_display"] : c["psnr"];
    EXPECT_NEAR(s.ssim, want_ssim.get<double>(), 1e-4);
    if (want_psnr.is_null()) {
      EXPECT_TRUE(s.identical);
      EXPECT_FALSE(s.psnr.has_value());
    } else {
      EXPECT_FALSE(s.identical);
      ASSERT_TRUE(s.psnr.has_value());
      EXPECT_NEAR(*s.psnr, want_psnr.get<double>(), 0.01);
    }
    if (c.contains("rmse_linear")) EXPECT_NEAR(s.rmse, c["rmse_linear"].get<double>(), 1e-6);
    // evaluate() agrees with the metrics called one by one.
    EXPECT_DOUBLE_EQ(s.flip.mean, f.stats.mean);
    EXPECT_DOUBLE_EQ(s.ssim, ssim(ref, test));
    EXPECT_DOUBLE_EQ(s.rmse, rmse(ref, test));
  }
}

// LDR-FLIP written straight from HPG 2020 with 2-D (not separable) filters, clamp-to-edge borders
// and double precision: an independent check of the library's separable, tiled, vectorised code on
// sizes the conformance set does not have (smaller than the filters, odd shapes, many tiles).
std::vector<double> naive_ldr_flip(const io::Image& ref, const io::Image& test, double ppd) {
  const int w = ref.width, h = ref.height;
  const double pi = 3.14159265358979;
  auto rgb = [](const io::Image& im, int x, int y, int c) {
    return double(im.at(x, y, im.channels == 1 ? 0 : c));
  };
  auto decode = [](double v) {
    return std::clamp(v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4), 0.0, 1.0);
  };
  const double m[3][3] = {{0.4123865632529917, 0.357584339383878, 0.1804807884018343},
                          {0.21263900587151036, 0.715168678767756, 0.07219231536073371},
                          {0.019330818715591832, 0.11919477979462598, 0.9505321522496607}};
  const double white[3] = {0.950428545, 1.0, 1.088900371};
  // YCxCz planes of both images.
  std::vector<std::array<double, 3>> ycc[2];
  for (int i = 0; i < 2; ++i) {
    const io::Image& im = i == 0 ? ref : test;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        double l[3], xyz[3];
        for (int c = 0; c < 3; ++c) l[c] = decode(rgb(im, x, y, c));
        for (int r = 0; r < 3; ++r)
          xyz[r] = (m[r][0] * l[0] + m[r][1] * l[1] + m[r][2] * l[2]) / white[r];
        ycc[i].push_back({116 * xyz[1] - 16, 500 * (xyz[0] - xyz[1]), 200 * (xyz[1] - xyz[2])});
      }
  }
  auto at = [&](int i, int x, int y) {
    return ycc[i][size_t(std::clamp(y, 0, h - 1)) * size_t(w) + size_t(std::clamp(x, 0, w - 1))];
  };
  // Spatial CSF filters, 2-D, each normalised to sum 1.
  const int rs = int(std::ceil(3 * std::sqrt(0.04 / (2 * pi * pi)) * ppd));
  auto csf = [&](double d2, double a, double b) {
    return a * std::sqrt(pi / b) * std::exp(-pi * pi * d2 / b);
  };
  std::vector<double> fy, fx, fz;
  double sy = 0, sx = 0, sz = 0;
  for (int j = -rs; j <= rs; ++j)
    for (int i = -rs; i <= rs; ++i) {
      const double d2 = (i * i + j * j) / (ppd * ppd);
      fy.push_back(csf(d2, 1, 0.0047));
      fx.push_back(csf(d2, 1, 0.0053));
      fz.push_back(csf(d2, 34.1, 0.04) + csf(d2, 13.5, 0.025));
      sy += fy.back();
      sx += fx.back();
      sz += fz.back();
    }
  // Feature filters: Gaussian and derivatives, signed parts normalised to +-1.
  const double sd = 0.5 * 0.082 * ppd;
  const int rf = int(std::ceil(3 * sd));
  std::vector<double> g, dg, ddg;
  double gs = 0, dp = 0, dn = 0, ddp = 0, ddn = 0;
  for (int i = -rf; i <= rf; ++i) {
    const double e = std::exp(-(i * i) / (2 * sd * sd));
    g.push_back(e);
    dg.push_back(-i * e);
    ddg.push_back((i * i / (sd * sd) - 1) * e);
    gs += e;
    (dg.back() > 0 ? dp : dn) += std::fabs(dg.back());
    (ddg.back() > 0 ? ddp : ddn) += std::fabs(ddg.back());
  }
  for (size_t i = 0; i < g.size(); ++i) {
    g[i] /= gs;
    dg[i] /= dg[i] > 0 ? dp : dn;
    ddg[i] /= ddg[i] > 0 ? ddp : ddn;
  }
  auto hunt_lab = [&](std::array<double, 3> v) {
    const double fy0 = (v[0] + 16) / 116;
    const double xyz[3] = {(fy0 + v[1] / 500) * white[0], fy0, (fy0 - v[2] / 200) * white[2]};
    const double inv[3][3] = {{3.241003275, -1.537398934, -0.498615861},
                              {-0.969224334, 1.875930071, 0.041554224},
                              {0.055639423, -0.204011202, 1.057148933}};
    double l[3], q[3];
    for (int r = 0; r < 3; ++r)
      l[r] = std::clamp(inv[r][0] * xyz[0] + inv[r][1] * xyz[1] + inv[r][2] * xyz[2], 0.0, 1.0);
    for (int r = 0; r < 3; ++r) {
      const double t = (m[r][0] * l[0] + m[r][1] * l[1] + m[r][2] * l[2]) / white[r];
      q[r] = t > std::pow(6.0 / 29, 3) ? std::cbrt(t) : t / (3 * std::pow(6.0 / 29, 2)) + 4.0 / 29;
    }
    const double L = 116 * q[1] - 16;
    return std::array<double, 3>{L, 0.01 * L * 500 * (q[0] - q[1]), 0.01 * L * 200 * (q[1] - q[2])};
  };
  auto hyab = [](std::array<double, 3> a, std::array<double, 3> b) {
    return std::fabs(a[0] - b[0]) + std::hypot(a[1] - b[1], a[2] - b[2]);
  };
  const double cmax =
      std::pow(hyab(hunt_lab({116 * 0.715168678767756 - 16,
                              500 * (0.357584339383878 / 0.950428545 - 0.715168678767756),
                              200 * (0.715168678767756 - 0.11919477979462598 / 1.088900371)}),
                    hunt_lab({116 * 0.07219231536073371 - 16,
                              500 * (0.1804807884018343 / 0.950428545 - 0.07219231536073371),
                              200 * (0.07219231536073371 - 0.9505321522496607 / 1.088900371)})),
               0.7);
  const double pccmax = 0.4 * cmax;
  std::vector<double> out;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      std::array<double, 3> f[2];
      double edge[2], point[2];
      for (int i = 0; i < 2; ++i) {
        double a = 0, b = 0, c = 0;
        size_t k = 0;
        for (int dy = -rs; dy <= rs; ++dy)
          for (int dx = -rs; dx <= rs; ++dx, ++k) {
            const auto v = at(i, x + dx, y + dy);
            a += fy[k] * v[0];
            b += fx[k] * v[1];
            c += fz[k] * v[2];
          }
        f[i] = {a / sy, b / sx, c / sz};
        double gx = 0, gy = 0, hx = 0, hy = 0;
        for (int dy = -rf; dy <= rf; ++dy)
          for (int dx = -rf; dx <= rf; ++dx) {
            const double yn = (at(i, x + dx, y + dy)[0] + 16) / 116;
            gx += dg[size_t(dx + rf)] * g[size_t(dy + rf)] * yn;
            gy += g[size_t(dx + rf)] * dg[size_t(dy + rf)] * yn;
            hx += ddg[size_t(dx + rf)] * g[size_t(dy + rf)] * yn;
            hy += g[size_t(dx + rf)] * ddg[size_t(dy + rf)] * yn;
          }
        edge[i] = std::hypot(gx, gy);
        point[i] = std::hypot(hx, hy);
      }
      double cd = std::pow(hyab(hunt_lab(f[0]), hunt_lab(f[1])), 0.7);
      cd = cd < pccmax ? cd * 0.95 / pccmax : 0.95 + (cd - pccmax) / (cmax - pccmax) * 0.05;
      const double fd = std::sqrt(
          std::max(std::fabs(edge[0] - edge[1]), std::fabs(point[0] - point[1])) / std::sqrt(2.0));
      out.push_back(std::pow(cd, 1 - fd));
    }
  return out;
}

io::Image random_ldr(int w, int h, int channels, unsigned seed) {
  std::mt19937 rng(seed);
  io::Image im(w, h, channels, false);
  for (float& v : im.pixels) v = float(rng() % 256) / 255.f;
  return im;
}

// Runs `check` under every build of the metrics' hot loops this CPU runs (metrics.h: VectorPath),
// then restores the one in use, so a lane or an edge that one build drops shows in its own trace.
template <typename Check>
void for_each_vector_path(const Check& check) {
  const VectorPath in_use = vector_path();
  for (VectorPath path : {VectorPath::baseline, VectorPath::avx2, VectorPath::avx512}) {
    if (!cpu_runs(path)) continue;
    SCOPED_TRACE(to_string(path));
    use_vector_path(path);
    check();
  }
  use_vector_path(in_use);
}

TEST(Flip, MatchesAStraightTwoDimensionalImplementation) {
  struct Case {
    int w, h, channels;
  };
  // Smaller than the filters, one row, one column, two pixels wide or tall, several 96x512 tiles
  // with ragged edges, RGBA (alpha must be ignored) and grey; widths that are no multiple of any
  // vector width.
  for (const Case c :
       {Case{1, 1, 3}, Case{5, 3, 3}, Case{37, 1, 3}, Case{1, 29, 3}, Case{2, 9, 3}, Case{13, 2, 3},
        Case{300, 70, 4}, Case{23, 17, 1}, Case{533, 5, 3}, Case{7, 101, 3}}) {
    SCOPED_TRACE(::testing::Message() << c.w << "x" << c.h << "x" << c.channels);
    io::Image ref = random_ldr(c.w, c.h, c.channels, 1), test = random_ldr(c.w, c.h, c.channels, 2);
    // Keep some structure (half the test equals the reference) so errors span a range.
    for (int y = 0; y < c.h; ++y)
      for (int x = 0; x < c.w / 2; ++x)
        for (int k = 0; k < c.channels; ++k) test.at(x, y, k) = ref.at(x, y, k);
    const std::vector<double> want = naive_ldr_flip(ref, test, kDefaultPixelsPerDegree);
    double mean = 0;
    for (double v : want) mean += v / double(want.size());
    for_each_vector_path([&] {
      const FlipResult f = flip(ref, test);
      // FLIP computes in float (as the reference tool does); where the colour distance is near 0,
      // x^0.7 magnifies float rounding (grey images have chroma of rounding size) to a few 1e-4.
      // A wrong border, tile seam or channel would be off by far more.
      double worst = 0;
      for (size_t i = 0; i < want.size(); ++i)
        worst = std::max(worst, std::fabs(double(f.error_map.pixels[i]) - want[i]));
      EXPECT_LT(worst, 1e-3);
      EXPECT_NEAR(f.stats.mean, mean, 1e-4);
    });
  }
}

TEST(Flip, SameBitsWhateverTheThreadCount) {
  const io::Image ref = random_ldr(700, 150, 3, 3), test = random_ldr(700, 150, 3, 4);
  io::Image hdr_ref = ref, hdr_test = test;
  hdr_ref.linear = hdr_test.linear = true;
  FlipResult one, one_hdr;
  {
    tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    one = flip(ref, test);
    one_hdr = flip(hdr_ref, hdr_test);
  }
  const FlipResult many = flip(ref, test), many_hdr = flip(hdr_ref, hdr_test);
  EXPECT_EQ(one.error_map.pixels, many.error_map.pixels);
  EXPECT_EQ(one_hdr.error_map.pixels, many_hdr.error_map.pixels);
  EXPECT_EQ(ssim(ref, test), [&] {
    tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    return ssim(ref, test);
  }());
}

// The AVX2 and AVX-512 builds fuse each filter tap's multiply-add and sum a value's taps in one
// order, whatever their vector width and register blocking (flip.cpp, "Filters in registers"), and
// the per-pixel maths is the same IEEE operations in every lane: their error maps match bit for
// bit, LDR and HDR, across tile seams and ragged right edges. (The baseline build rounds each
// product separately and differs in the last bits.)
TEST(Flip, AvxBuildsGiveTheSameBits) {
  if (!cpu_runs(VectorPath::avx2) || !cpu_runs(VectorPath::avx512))
    GTEST_SKIP() << "this CPU does not run both the AVX2 and the AVX-512 builds";
  const io::Image ref = card(1061, 203, 5), test = random_ldr(1061, 203, 3, 6);
  io::Image hdr_ref = ref, hdr_test = test;
  hdr_ref.linear = hdr_test.linear = true;
  const VectorPath in_use = vector_path();
  use_vector_path(VectorPath::avx2);
  const FlipResult avx2 = flip(ref, test), avx2_hdr = flip(hdr_ref, hdr_test);
  use_vector_path(VectorPath::avx512);
  const FlipResult avx512 = flip(ref, test), avx512_hdr = flip(hdr_ref, hdr_test);
  use_vector_path(in_use);
  EXPECT_EQ(avx2.error_map.pixels, avx512.error_map.pixels);
  EXPECT_EQ(avx2_hdr.error_map.pixels, avx512_hdr.error_map.pixels);
  EXPECT_GT(avx2.stats.mean, 0.0);
}

TEST(Flip, IdenticalImagesScoreZeroOneAndIdentical) {
  for (bool linear : {false, true}) {
    io::Image a = card(48, 40, 7);
    a.linear = linear;
    const Scores s = evaluate(a, a);
    EXPECT_EQ(s.flip.mean, 0.0);
    EXPECT_EQ(s.flip.max, 0.0);
    EXPECT_EQ(s.flip.weighted_median, 0.0);
    EXPECT_NEAR(s.ssim, 1.0, 1e-12);
    EXPECT_TRUE(s.identical);
    EXPECT_FALSE(s.psnr.has_value());
    EXPECT_EQ(s.rmse, 0.0);
    EXPECT_EQ(s.mae, 0.0);
    EXPECT_EQ(s.relmse, 0.0);
  }
}

TEST(Flip, BlackAgainstWhiteMatchesTheReferenceTool) {
  const io::Image black = constant(64, 64, 0, 0, 0, false);
  const io::Image white = constant(64, 64, 1, 1, 1, false);
  const FlipResult f = flip(black, white);
  // The reference tool's 0.9673, to the conformance tolerance. (Worked out without rounding, the
  // colour error of black against white is 0.96738; float rounding in the derivative filters,
  // amplified by the feature exponent 1/2, moves it by about 1e-5 in the tool and here alike.)
  EXPECT_NEAR(f.stats.mean, 0.9673, 1e-4);
  // A uniform pair has no features: every pixel carries the same colour error.
  EXPECT_NEAR(f.stats.min, f.stats.max, 1e-6);
}

TEST(Flip, ErrorGrowsWithTheDifference) {
  const io::Image ref = card(64, 48, 3);
  double last = 0;
  for (float offset : {0.02f, 0.05f, 0.1f, 0.2f}) {
    io::Image test = ref;
    for (float& v : test.pixels) v = std::min(1.f, v + offset);
    const double mean = flip(ref, test).stats.mean;
    EXPECT_GT(mean, last) << offset;
    last = mean;
  }
}

TEST(Flip, HdrOptionsChangeTheExposureRange) {
  io::Image ref = card(40, 40, 11), test = card(40, 40, 12);
  for (io::Image* im : {&ref, &test}) {
    im->linear = true;
    for (float& v : im->pixels) v *= 4.f;
  }
  FlipOptions o;
  o.start_exposure = -3.0;
  o.stop_exposure = 1.0;
  o.num_exposures = 5;
  const FlipResult f = flip(ref, test, o);
  ASSERT_TRUE(f.exposures.has_value());
  EXPECT_EQ(f.exposures->start, -3.0);
  EXPECT_EQ(f.exposures->stop, 1.0);
  EXPECT_EQ(f.exposures->count, 5);
  // Every tone mapper gives a valid, different error.
  double aces = flip(ref, test).stats.mean;
  o = {};
  o.tonemapper = Tonemapper::hable;
  double hable = flip(ref, test, o).stats.mean;
  o.tonemapper = Tonemapper::reinhard;
  double reinhard = flip(ref, test, o).stats.mean;
  for (double m : {aces, hable, reinhard}) {
    EXPECT_GT(m, 0.0);
    EXPECT_LT(m, 1.0);
  }
  EXPECT_NE(aces, hable);
  EXPECT_NE(aces, reinhard);
  // More exposures can only raise a pixel's maximum over exposures at the shared ones.
  o = {};
  o.start_exposure = -3.0;
  o.stop_exposure = 1.0;
  o.num_exposures = 2;
  const FlipResult two = flip(ref, test, o);
  o.num_exposures = 3;  // -3, -1, 1 contains -3 and 1
  const FlipResult three = flip(ref, test, o);
  for (size_t i = 0; i < two.error_map.pixels.size(); ++i)
    ASSERT_GE(three.error_map.pixels[i], two.error_map.pixels[i]);
}

TEST(Flip, WeightedQuantilesFollowTheReferencePooling) {
  // Errors 0.1 (x6) and 0.4 (x2): total 1.4. The 0.25 quantile is where the sorted running sum
  // passes 0.35 (the 4th 0.1), the median 0.7 is passed by the 1st 0.4 (0.6 + 0.4), 0.75 too.
  io::Image e(8, 1, 1, false);
  const float values[8] = {0.4f, 0.1f, 0.1f, 0.1f, 0.4f, 0.1f, 0.1f, 0.1f};
  std::copy(values, values + 8, e.pixels.begin());
  const FlipStats s = pool_flip(e);
  EXPECT_NEAR(s.mean, 1.4 / 8, 1e-7);
  EXPECT_FLOAT_EQ(float(s.q1), 0.1f);
  EXPECT_FLOAT_EQ(float(s.weighted_median), 0.4f);
  EXPECT_FLOAT_EQ(float(s.q3), 0.4f);
  EXPECT_FLOAT_EQ(float(s.min), 0.1f);
  EXPECT_FLOAT_EQ(float(s.max), 0.4f);
  // Against a brute-force sort on many values spread over many buckets.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  io::Image big(300, 200, 1, false);
  for (float& v : big.pixels) v = u(rng) * u(rng);
  std::vector<float> sorted = big.pixels;
  std::sort(sorted.begin(), sorted.end());
  double total = 0;
  for (float v : sorted) total += v;
  auto brute = [&](double p) {
    double run = 0;
    for (float v : sorted)
      if ((run += v) > p * total) return double(v);
    return double(sorted.back());
  };
  const FlipStats b = pool_flip(big);
  EXPECT_EQ(b.q1, brute(0.25));
  EXPECT_EQ(b.weighted_median, brute(0.5));
  EXPECT_EQ(b.q3, brute(0.75));
}

// scikit-image's SSIM (the settings of ssim.cpp) summed window by window in long double: the 11x11
// Gaussian weights of each output pixel applied directly, no separable passes, no vectors.
double naive_ssim(const io::Image& a, const io::Image& b) {
  constexpr int r = 5;
  long double w[2 * r + 1], sum = 0;
  for (int i = -r; i <= r; ++i) sum += w[i + r] = std::exp(-0.5L * i * i / (1.5L * 1.5L));
  for (long double& v : w) v /= sum;
  auto value = [](const io::Image& im, int x, int y, int c) {  // 8-bit codes, as k / 255
    return std::round(static_cast<long double>(im.at(x, y, std::min(c, im.channels - 1))) * 255) /
           255;
  };
  long double total = 0;
  for (int c = 0; c < 3; ++c) {
    long double map_sum = 0;
    for (int y = r; y < a.height - r; ++y)
      for (int x = r; x < a.width - r; ++x) {
        long double ux = 0, uy = 0, uxx = 0, uyy = 0, uxy = 0;
        for (int dy = -r; dy <= r; ++dy)
          for (int dx = -r; dx <= r; ++dx) {
            const long double k = w[dy + r] * w[dx + r];
            const long double p = value(a, x + dx, y + dy, c), q = value(b, x + dx, y + dy, c);
            ux += k * p;
            uy += k * q;
            uxx += k * p * p;
            uyy += k * q * q;
            uxy += k * p * q;
          }
        const long double vx = uxx - ux * ux, vy = uyy - uy * uy, vxy = uxy - ux * uy;
        map_sum += (2 * ux * uy + 1e-4L) * (2 * vxy + 9e-4L) /
                   ((ux * ux + uy * uy + 1e-4L) * (vx + vy + 9e-4L));
      }
    total += map_sum / ((a.width - 2 * r) * (a.height - 2 * r));
  }
  return double(total / 3);
}

TEST(Ssim, EveryVectorBuildMatchesAStraightWindowSum) {
  struct Case {
    int w, h, channels;
  };
  // The smallest image (one output pixel), widths whose 10 fewer output columns leave every
  // remainder modulo 2, 4 and 8 vectors, grey and RGBA, and heights across a 64-row block.
  for (const Case c : {Case{11, 11, 3}, Case{12, 13, 3}, Case{13, 11, 1}, Case{14, 12, 3},
                       Case{15, 11, 4}, Case{17, 14, 3}, Case{18, 11, 3}, Case{19, 12, 3},
                       Case{21, 11, 3}, Case{26, 16, 3}, Case{31, 75, 3}}) {
    SCOPED_TRACE(::testing::Message() << c.w << "x" << c.h << "x" << c.channels);
    const io::Image a = random_ldr(c.w, c.h, c.channels, 5);
    io::Image b = random_ldr(c.w, c.h, c.channels, 6);
    for (int y = 0; y < c.h; ++y)  // a correlated half, so the map spans a range
      for (int x = 0; x < c.w / 2; ++x)
        for (int k = 0; k < c.channels; ++k) b.at(x, y, k) = a.at(x, y, k);
    const double want = naive_ssim(a, b);
    // Separable passes and vectors reorder the sums: ~1e-15. One output column dropped or
    // counted twice moves the mean by more than 1e-3 at these widths.
    for_each_vector_path([&] { EXPECT_NEAR(ssim(a, b), want, 1e-12); });
  }
  // Narrower than the window: refused in every build.
  for_each_vector_path([] {
    EXPECT_THROW(ssim(random_ldr(2, 40, 3, 1), random_ldr(2, 40, 3, 2)), InputError);
    EXPECT_THROW(ssim(random_ldr(10, 11, 3, 1), random_ldr(10, 11, 3, 2)), InputError);
  });
}

TEST(Ssim, KnownValuesAndSymmetry) {
  const io::Image a = card(40, 32, 1), b = card(40, 32, 2);
  EXPECT_NEAR(ssim(a, a), 1.0, 1e-12);
  EXPECT_NEAR(ssim(a, b), ssim(b, a), 1e-12);
  EXPECT_LT(ssim(a, b), 0.99);
  // Two constant images: the map is (2 m n + C1) / (m^2 + n^2 + C1) everywhere.
  const double m = 0.2, n = 0.6, c1 = 1e-4;
  EXPECT_NEAR(ssim(constant(16, 16, float(m), float(m), float(m), false),
                   constant(16, 16, float(n), float(n), float(n), false)),
              (2 * m * n + c1) / (m * m + n * n + c1), 1e-6);
  EXPECT_THROW(ssim(constant(8, 8, 0, 0, 0, false), constant(8, 8, 0, 0, 0, false)), InputError);
}

TEST(Psnr, ConstantOffsetGivesTheExactValue) {
  // Every value 51/255 higher: MSE = (51/255)^2 = 0.04, PSNR = 10 log10(1 / 0.04) = 13.9794 dB.
  io::Image ref = card(32, 32, 9);
  for (float& v : ref.pixels) v = std::min(v, 200.f / 255.f);
  io::Image test = ref;
  for (float& v : test.pixels) v = (std::round(v * 255.f) + 51.f) / 255.f;
  const Psnr p = psnr(ref, test);
  ASSERT_TRUE(p.db.has_value());
  EXPECT_FALSE(p.identical);
  EXPECT_NEAR(*p.db, 10.0 * std::log10(1.0 / 0.04), 1e-9);
  // HDR values above 1 clamp to the same display value: identical for PSNR.
  const io::Image bright = constant(16, 16, 2.f, 3.f, 4.f, true);
  const io::Image brighter = constant(16, 16, 5.f, 6.f, 7.f, true);
  EXPECT_TRUE(psnr(bright, brighter).identical);
  EXPECT_GT(rmse(bright, brighter), 2.9);
}

// PSNR, RMSE, MAE and relMSE under every vector build against a plain double loop, on widths that
// are no multiple of any vector width (the rows' remainders) and on one of several vectors.
TEST(PixelMetrics, EveryVectorBuildMatchesAPlainSum) {
  for (int w : {1, 3, 7, 9, 37, 533}) {
    SCOPED_TRACE(::testing::Message() << "width " << w);
    io::Image ref = random_ldr(w, 5, 3, 3), test = random_ldr(w, 5, 3, 4);
    double sq = 0, sq_lin = 0, abs_lin = 0, rel_lin = 0;
    // 8-bit values as the metrics read them (k / 255 in double); PSNR sees them as they are, the
    // linear metrics sRGB decoded.
    auto stored = [](float v) { return std::round(double(v) * 255.0) / 255.0; };
    auto linear = [](double v) {
      return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
    };
    for (size_t i = 0; i < ref.pixels.size(); ++i) {
      const double d = stored(test.pixels[i]) - stored(ref.pixels[i]);
      sq += d * d;
      const double r = linear(stored(ref.pixels[i])), dl = linear(stored(test.pixels[i])) - r;
      sq_lin += dl * dl, abs_lin += std::fabs(dl), rel_lin += dl * dl / (r * r + 0.01);
    }
    const double n = double(ref.pixels.size());
    for_each_vector_path([&] {
      EXPECT_NEAR(*psnr(ref, test).db, 10.0 * std::log10(n / sq), 1e-9);
      EXPECT_NEAR(rmse(ref, test), std::sqrt(sq_lin / n), 1e-9);
      EXPECT_NEAR(mae(ref, test), abs_lin / n, 1e-9);
      EXPECT_NEAR(relmse(ref, test), rel_lin / n, 1e-9);
    });
  }
}

TEST(PixelMetrics, HandComputedValues) {
  // Linear (HDR) 2x1 images: reference (1, 0.5) grey, test (1.5, 0.5) grey.
  io::Image ref(2, 1, 3, true), test(2, 1, 3, true);
  for (int c = 0; c < 3; ++c) {
    ref.at(0, 0, c) = 1.f;
    ref.at(1, 0, c) = 0.5f;
    test.at(0, 0, c) = 1.5f;
    test.at(1, 0, c) = 0.5f;
  }
  EXPECT_NEAR(rmse(ref, test), std::sqrt(0.25 / 2), 1e-12);
  EXPECT_NEAR(mae(ref, test), 0.25, 1e-12);
  EXPECT_NEAR(relmse(ref, test), (0.25 / 1.01) / 2, 1e-12);
  // LDR values are decoded to linear first: sRGB 188/255 is linear 0.5029, 255/255 is 1.
  io::Image lref = constant(1, 1, 188 / 255.f, 188 / 255.f, 188 / 255.f, false);
  io::Image ltest = constant(1, 1, 1.f, 1.f, 1.f, false);
  const double lin = std::pow((188 / 255.0 + 0.055) / 1.055, 2.4);
  EXPECT_NEAR(mae(lref, ltest), 1.0 - lin, 1e-12);
  EXPECT_NEAR(relmse(lref, ltest), (1 - lin) * (1 - lin) / (lin * lin + 0.01), 1e-12);
  // Alpha is ignored; grey images count as three equal channels.
  io::Image rgba(1, 1, 4, true), rgba_test(1, 1, 4, true);
  rgba.pixels = {1, 1, 1, 0};
  rgba_test.pixels = {1, 1, 1, 1};
  EXPECT_EQ(rmse(rgba, rgba_test), 0.0);
  io::Image grey(1, 1, 1, true), grey_test(1, 1, 1, true);
  grey.pixels = {0.5f};
  grey_test.pixels = {1.0f};
  EXPECT_NEAR(mae(grey, grey_test), 0.5, 1e-12);
}

TEST(Metrics, BadInputsThrowInputError) {
  const io::Image a = constant(16, 16, 0.5f, 0.5f, 0.5f, false);
  const io::Image b = constant(16, 12, 0.5f, 0.5f, 0.5f, false);
  EXPECT_THROW(flip(a, b), InputError);
  EXPECT_THROW(evaluate(a, b), InputError);
  io::Image hdr = a;
  hdr.linear = true;
  EXPECT_THROW(psnr(a, hdr), InputError);
  io::Image nan = hdr;
  nan.pixels[5] = std::nanf("");
  EXPECT_THROW(rmse(hdr, nan), InputError);
  io::Image two(16, 16, 2, false);
  EXPECT_THROW(ssim(a, two), InputError);
  FlipOptions bad;
  bad.pixels_per_degree = 0;
  EXPECT_THROW(flip(a, a, bad), InputError);
  EXPECT_THROW(parse_tonemapper("filmic"), InputError);
  EXPECT_EQ(parse_tonemapper("ACES"), Tonemapper::aces);
}

// Scoring leaves FLIP out when the config's metrics do not name it (MetricSelection): evaluate()
// and noise_floor() then give FLIP zero, no error map, and every other score exactly as with FLIP.
TEST(Metrics, SelectionWithoutFlipKeepsEveryOtherScore) {
  io::Image half_a = card(48, 40, 1), half_b = card(48, 40, 2), test = card(48, 40, 3);
  half_a.linear = half_b.linear = test.linear = true;
  io::Image mean = half_a, variance = half_a;
  for (size_t i = 0; i < mean.pixels.size(); ++i) {
    const float d = 0.5f * (half_a.pixels[i] - half_b.pixels[i]);
    mean.pixels[i] = 0.5f * (half_a.pixels[i] + half_b.pixels[i]);
    variance.pixels[i] = d * d;
  }
  const MetricSelection without_flip{.flip = false};
  io::Image error_map;
  const Scores all = evaluate(mean, test);
  const Scores some = evaluate(mean, test, {}, &error_map, without_flip);
  EXPECT_GT(all.flip.mean, 0.0);
  EXPECT_EQ(some.flip.mean, 0.0);
  EXPECT_EQ(some.flip.max, 0.0);
  EXPECT_TRUE(error_map.pixels.empty());
  EXPECT_EQ(some.ssim, all.ssim);
  EXPECT_EQ(some.psnr, all.psnr);
  EXPECT_EQ(some.rmse, all.rmse);
  EXPECT_EQ(some.mae, all.mae);
  EXPECT_EQ(some.relmse, all.relmse);
  const NoisyReference reference{mean, variance, half_a, half_b};
  const NoiseFloor full = noise_floor(reference), part = noise_floor(reference, {}, without_flip);
  EXPECT_GT(full.scores.flip.mean, 0.0);
  EXPECT_EQ(part.scores.flip.mean, 0.0);
  EXPECT_EQ(part.scores.ssim, full.scores.ssim);
  EXPECT_EQ(part.scores.psnr, full.scores.psnr);
  EXPECT_EQ(part.scores.rmse, full.scores.rmse);
  EXPECT_EQ(part.scores.mae, full.scores.mae);
  EXPECT_EQ(part.scores.relmse, full.scores.relmse);
  EXPECT_EQ(part.mse_from_halves, full.mse_from_halves);
}

TEST(TemporalInstability, ZeroWhenTheTestChangesAsTheReference) {
  std::vector<io::Image> ref, test;
  for (unsigned t = 0; t < 4; ++t) {
    ref.push_back(card(24, 16, t));
    test.push_back(ref.back());
  }
  EXPECT_EQ(temporal_instability(ref, test), 0.0);
  // A constant offset (same error every frame) does not flicker either.
  for (auto& frame : test)
    for (float& v : frame.pixels) v = std::min(1.f, v + 10 / 255.f);
  EXPECT_LT(temporal_instability(ref, test), 0.01);
}

TEST(TemporalInstability, FlickerScoresWorseThanSteadyErrorOfEqualSize) {
  // A static grey reference; two tests with the same per-frame error |0.1| in display values:
  // one always brighter (steady), one alternating brighter/darker (flicker).
  std::vector<io::Image> ref, steady, flicker;
  for (int t = 0; t < 6; ++t) {
    ref.push_back(constant(8, 8, 0.5f, 0.5f, 0.5f, false));
    steady.push_back(constant(8, 8, 0.6f, 0.6f, 0.6f, false));
    const float v = t % 2 ? 0.4f : 0.6f;
    flicker.push_back(constant(8, 8, v, v, v, false));
  }
  EXPECT_NEAR(psnr(ref[0], steady[0]).db.value(), psnr(ref[1], flicker[1]).db.value(), 1e-6);
  EXPECT_NEAR(temporal_instability(ref, steady), 0.0, 1e-7);
  // Luma weights sum to 1, so the alternating 0.2 step shows as 0.2 per pair.
  EXPECT_NEAR(temporal_instability(ref, flicker), 0.2, 1e-6);
  EXPECT_THROW(temporal_instability({ref[0]}, {ref[0]}), InputError);
}

TEST(Magma, EndsAndRounding) {
  io::Image e(3, 1, 1, false);
  e.pixels = {0.f, 1.f, 0.5f};
  const io::Image m = magma(e);
  ASSERT_EQ(m.channels, 3);
  EXPECT_FALSE(m.linear);
  EXPECT_NEAR(m.at(0, 0, 0), 0.001462f, 1e-7);  // matplotlib magma[0]
  EXPECT_NEAR(m.at(0, 0, 2), 0.013866f, 1e-7);
  EXPECT_NEAR(m.at(1, 0, 0), 0.987053f, 1e-7);  // magma[255]
  EXPECT_NEAR(m.at(1, 0, 1), 0.991438f, 1e-7);
  EXPECT_NEAR(m.at(2, 0, 0), 0.716387f, 1e-7);  // round(0.5 * 255) = 128
}

}  // namespace metrics_test
}  // namespace pb::metrics
