// Noise floors (noise_floor.h): closed forms from the variance image and the halves, a perturbation
// estimate for FLIP, and the unbiased squared errors.
#include "metrics/noise_floor.h"

#include <fmt/format.h>
#include <tbb/enumerable_thread_specific.h>

#include <cmath>
#include <vector>

#include "metrics/detail.h"
#include "photonbench/error.h"

namespace pb::metrics {
namespace {

using detail::Values;

void check_same_shape(const io::Image& mean, const io::Image& other, const char* role) {
  detail::check_pair(mean, other, fmt::format("noise floor ({})", role));
  if (other.channels != mean.channels)
    throw InputError(fmt::format("noise floor: the {} image has {} channels, the mean {}", role,
                                 other.channels, mean.channels));
}

void check_reference(const NoisyReference& r) {
  if (!r.mean.linear)
    throw InputError("noise floor: the reference mean is LDR; floors need linear radiance");
  check_same_shape(r.mean, r.variance, "variance");
  check_same_shape(r.mean, r.half_a, "first half");
  check_same_shape(r.mean, r.half_b, "second half");
}

// Sums over pixels and colour channels of row_term(a, b, c, n) on `values` of three images (rows
// converted once), in row order: the result does not depend on scheduling.
template <typename RowTerm>
double sum_values(Values values, const io::Image& a, const io::Image& b, const io::Image& c,
                  const RowTerm& row_term) {
  const size_t w = size_t(a.width);
  tbb::enumerable_thread_specific<std::vector<double>> rows(
      [w] { return std::vector<double>(3 * w); });
  return detail::sum_rows(0, a.height, [&](int y) {
    std::vector<double>& buf = rows.local();
    double* ra = buf.data();
    double* rb = ra + w;
    double* rc = rb + w;
    double s = 0;
    for (int ch = 0; ch < 3; ++ch) {
      detail::convert_row(a, y, ch, values, ra);
      detail::convert_row(b, y, ch, values, rb);
      detail::convert_row(c, y, ch, values, rc);
      s += row_term(ra, rb, rc, w);
    }
    return s;
  });
}

// R + d and R - d for a perturbation d(i) of each colour value i, clamped at 0 (the true image is
// never negative; with equal halves R - d = H2 >= 0 anyway); alpha is kept.
template <typename Perturbation>
std::pair<io::Image, io::Image> perturbed_pair(const io::Image& mean, const Perturbation& d) {
  io::Image plus = mean, minus = mean;
  const size_t channels = size_t(mean.channels), colours = std::min<size_t>(channels, 3);
  tbb::parallel_for(0, mean.height, [&](int y) {
    const size_t row = size_t(y) * size_t(mean.width) * channels;
    for (size_t i = row; i < row + size_t(mean.width) * channels; i += channels)
      for (size_t c = i; c < i + colours; ++c) {
        const double delta = d(c), m = double(mean.pixels[c]);
        plus.pixels[c] = float(std::max(0.0, m + delta));
        minus.pixels[c] = float(std::max(0.0, m - delta));
      }
  });
  return {std::move(plus), std::move(minus)};
}

// The FLIP statistics of the reference against the two perturbed images, averaged.
FlipStats mean_of_pair(const FlipStats& a, const FlipStats& b) {
  auto avg = [](double x, double y) { return 0.5 * (x + y); };
  return {avg(a.mean, b.mean), avg(a.weighted_median, b.weighted_median),
          avg(a.q1, b.q1),     avg(a.q3, b.q3),
          avg(a.min, b.min),   avg(a.max, b.max)};
}

double squared_difference_row(const double* a, const double* b, const double*, size_t w) {
  double s = 0;
  for (size_t x = 0; x < w; ++x) s += (a[x] - b[x]) * (a[x] - b[x]);
  return s;
}

// relMSE's weight w(R) = 1 / (R^2 + 0.01) (scores.cpp, error_sums_row) with its first two
// derivatives, for the expectations over R's noise n (R = T + n, E n = 0, E n^2 = Var, and to this
// order E n^3 = 0, E n^4 = 3 Var^2 as for Gaussian noise). With e = X - T:
//   E[(X - R)^2 w(R)] = e^2 w + Var w - 2 e w' Var + e^2 w'' Var / 2 + 3/2 w'' Var^2   (at T)
// The floor (e = 0) is Var w + 3/2 w'' Var^2; evaluated at R, Var w(R) has expectation
// Var w + w'' Var^2 / 2, so relmse_floor = mean(Var (w(R) + Var w''(R))). The unbiased relMSE takes
// off Var w and the cross term -2 e w' Var, at R and with X - R for e.
struct RelmseWeight {
  static constexpr double kOffset = 0.01;
  double w, slope, curvature;
  explicit RelmseWeight(double r) {
    const double q = r * r + kOffset;
    w = 1.0 / q;
    slope = -2.0 * r / (q * q);
    curvature = (6.0 * r * r - 2.0 * kOffset) / (q * q * q);
  }
};

}  // namespace

NoiseFloor noise_floor(const NoisyReference& reference, const FlipOptions& options,
                       const MetricSelection& selection) {
  check_reference(reference);
  const io::Image &r = reference.mean, &a = reference.half_a, &b = reference.half_b;
  const io::Image& v = reference.variance;
  const double n = 3.0 * double(r.pixel_count());
  NoiseFloor floor;

  // FLIP (and MAE): against R + d and R - d, d = (H1 - H2) / 2. With equally many samples in the
  // halves R + d = H1 and R - d = H2; with one more in a half, Var d exceeds Var R by a factor
  // n^2 / (n^2 - 1) for n samples in all: negligible.
  auto [plus, minus] =
      perturbed_pair(r, [&](size_t i) { return 0.5 * (double(a.pixels[i]) - b.pixels[i]); });
  const Scores up = evaluate(r, plus, options, nullptr, selection),
               down = evaluate(r, minus, options, nullptr, selection);
  floor.scores.flip = mean_of_pair(up.flip, down.flip);
  floor.scores.mae = 0.5 * (up.mae + down.mae);

  // SSIM: from the window statistics of R and of d (ssim.cpp, ssim_of_truth).
  floor.scores.ssim = detail::ssim_of_truth(r, a, b);

  // PSNR: 10 log10(1 / E mean((D(R) - D(T))^2)), the display-encoded noise power of R estimated by
  // mean(((D(H1) - D(H2)) / 2)^2) (D: the display encoding PSNR sees).
  const double display_mse =
      sum_values(Values::display, a, b, r, squared_difference_row) / (4.0 * n);
  floor.scores.identical = display_mse == 0.0;
  if (display_mse > 0) floor.scores.psnr = 10.0 * std::log10(1.0 / display_mse);

  // RMSE and relMSE in closed form from the variance image.
  floor.mse = sum_values(Values::linear, v, r, r,
                         [](const double* var, const double*, const double*, size_t w) {
                           double s = 0;
                           for (size_t x = 0; x < w; ++x) s += var[x];
                           return s;
                         }) /
              n;
  floor.scores.rmse = std::sqrt(floor.mse);
  floor.scores.relmse = sum_values(Values::linear, v, r, r,
                                   [](const double* var, const double* m, const double*, size_t w) {
                                     double s = 0;
                                     for (size_t x = 0; x < w; ++x) {
                                       const RelmseWeight k(m[x]);
                                       s += var[x] * (k.w + var[x] * k.curvature);
                                     }
                                     return s;
                                   }) /
                        n;
  floor.mse_from_halves = sum_values(Values::linear, a, b, r, squared_difference_row) / (4.0 * n);
  return floor;
}

UnbiasedErrors unbiased_errors(const NoisyReference& reference, const io::Image& test) {
  check_reference(reference);
  detail::check_pair(reference.mean, test, "unbiased errors");
  const io::Image &r = reference.mean, &v = reference.variance;
  const double n = 3.0 * double(r.pixel_count());
  UnbiasedErrors e;
  e.mse = sum_values(Values::linear, r, v, test,
                     [](const double* m, const double* var, const double* t, size_t w) {
                       double s = 0;
                       for (size_t x = 0; x < w; ++x) s += (t[x] - m[x]) * (t[x] - m[x]) - var[x];
                       return s;
                     }) /
          n;
  // relMSE weighs each squared error by w(R) = 1 / (R^2 + 0.01), a function of the noisy R
  // (RelmseWeight): besides Var w, the cross term of the error with the weight's slope comes off
  // (first order in the error: with a 10% error and 7% noise it is a fifth of err^2 w). The
  // curvature terms are left: on synthetic references they moved the estimate away from the truth
  // as often as towards it (noise_floor_test.cpp).
  e.relmse = sum_values(Values::linear, r, v, test,
                        [](const double* m, const double* var, const double* t, size_t w) {
                          double s = 0;
                          for (size_t x = 0; x < w; ++x) {
                            const RelmseWeight k(m[x]);
                            const double err = t[x] - m[x];
                            s += err * err * k.w - var[x] * (k.w - 2.0 * err * k.slope);
                          }
                          return s;
                        }) /
             n;
  return e;
}

}  // namespace pb::metrics
