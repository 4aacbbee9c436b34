// SSIM (Wang, Bovik, Sheikh and Simoncelli, IEEE TIP 13(4), 2004) as scikit-image's
// structural_similarity computes it with gaussian_weights=True, sigma=1.5,
// use_sample_covariance=False, data_range=1, channel by channel:
//   - local statistics from a Gaussian window (sigma 1.5, truncated at 3.5 sigma: radius 5,
//     11 taps, weights normalised to sum 1), separable, in float64;
//   - population (not sample) variances and covariance: E[x^2] - E[x]^2;
//   - the SSIM map (eq. 13 with C1 = (0.01 L)^2, C2 = (0.03 L)^2, L = 1) averaged over the pixels
//     at least 5 from the border (scikit-image crops the window radius, so no border rule is
//     ever used);
//   - the channels' means averaged.
#include <fmt/format.h>
#include <tbb/enumerable_thread_specific.h>

#include <array>
#include <cmath>
#include <vector>

#include "metrics/detail.h"
#include "metrics/metrics.h"
#include "photonbench/error.h"

namespace pb::metrics {
namespace {

using detail::Values;

constexpr double kSigma = 1.5;
constexpr int kRadius = 5;  // int(3.5 * sigma + 0.5), scipy's truncation
constexpr int kTaps = 2 * kRadius + 1;
constexpr double kC1 = 0.01 * 0.01, kC2 = 0.03 * 0.03;

std::array<double, kTaps> gaussian_window() {
  std::array<double, kTaps> w{};
  double sum = 0;
  for (int i = 0; i < kTaps; ++i) {
    const double x = i - kRadius;
    w[size_t(i)] = std::exp(-0.5 * x * x / (kSigma * kSigma));
    sum += w[size_t(i)];
  }
  for (double& v : w) v /= sum;
  return w;
}

// Eight doubles as one GCC vector: each lane gets exactly the scalar operations, in the same order,
// on every target clone (AVX-512: one register; AVX2: two; baseline: four). Read and written
// through an unaligned, aliasing view of the rows.
constexpr size_t kLanes = 8;
typedef double Lanes __attribute__((vector_size(kLanes * sizeof(double))));
typedef double LanesAt __attribute__((vector_size(kLanes * sizeof(double)), aligned(8), may_alias));

// Sum of the SSIM map over one output row and the columns [kRadius, width - kRadius), from the
// 11 input rows around it (xr, yr). scratch holds 6 * width doubles.
PB_METRICS_KERNEL double ssim_row(const double* const* xr, const double* const* yr, int width,
                                  const double* k, double* scratch) {
  const size_t w = size_t(width);
  double* __restrict mx = scratch;
  double* __restrict my = scratch + w;
  double* __restrict mxx = scratch + 2 * w;
  double* __restrict myy = scratch + 3 * w;
  double* __restrict mxy = scratch + 4 * w;
  double* __restrict s = scratch + 5 * w;
  // Vertical: the five windowed moments of every column, eight columns at a time in vectors (a
  // loop over columns with the taps inside stays scalar: GCC does not vectorise through the 22
  // row pointers). Every sum adds its taps in order from 0, as the scalar loop for the last
  // columns does, so each column gets the same bits either way.
  size_t j = 0;
  for (; j + kLanes <= w; j += kLanes) {
    Lanes sx = {}, sy = {}, sxx = {}, syy = {}, sxy = {};
    for (int t = 0; t < kTaps; ++t) {
      const Lanes a = *reinterpret_cast<const LanesAt*>(xr[t] + j);
      const Lanes b = *reinterpret_cast<const LanesAt*>(yr[t] + j);
      const double wt = k[t];
      sx += wt * a;
      sy += wt * b;
      sxx += wt * (a * a);
      syy += wt * (b * b);
      sxy += wt * (a * b);
    }
    *reinterpret_cast<LanesAt*>(mx + j) = sx;
    *reinterpret_cast<LanesAt*>(my + j) = sy;
    *reinterpret_cast<LanesAt*>(mxx + j) = sxx;
    *reinterpret_cast<LanesAt*>(myy + j) = syy;
    *reinterpret_cast<LanesAt*>(mxy + j) = sxy;
  }
  for (; j < w; ++j) {
    double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    for (int t = 0; t < kTaps; ++t) {
      const double a = xr[t][j], b = yr[t][j], wt = k[t];
      sx += wt * a;
      sy += wt * b;
      sxx += wt * (a * a);
      syy += wt * (b * b);
      sxy += wt * (a * b);
    }
    mx[j] = sx;
    my[j] = sy;
    mxx[j] = sxx;
    myy[j] = syy;
    mxy[j] = sxy;
  }
  // Horizontal, then the SSIM map (Wang et al. eq. 13).
  const size_t end = w - kRadius;
  for (size_t j = kRadius; j < end; ++j) {
    double ux = 0, uy = 0, uxx = 0, uyy = 0, uxy = 0;
#pragma GCC unroll 11
    for (int t = 0; t < kTaps; ++t) {
      const size_t i = j + size_t(t) - kRadius;
      ux += k[t] * mx[i];
      uy += k[t] * my[i];
      uxx += k[t] * mxx[i];
      uyy += k[t] * myy[i];
      uxy += k[t] * mxy[i];
    }
    const double vx = uxx - ux * ux, vy = uyy - uy * uy, vxy = uxy - ux * uy;
    const double a1 = 2 * ux * uy + kC1, a2 = 2 * vxy + kC2;
    const double b1 = ux * ux + uy * uy + kC1, b2 = vx + vy + kC2;
    s[j] = (a1 * a2) / (b1 * b2);
  }
  // Summed in eight lanes by column (lane = (j - kRadius) mod 8), the lanes then in order: a fixed
  // order for a given width, so results are reproducible whatever the threads or the alignment,
  // without a chain of one dependent addition per column.
  Lanes lanes = {};
  size_t j_sum = kRadius;
  for (; j_sum + kLanes <= end; j_sum += kLanes)
    lanes += *reinterpret_cast<const LanesAt*>(s + j_sum);
  double sum = 0;
  for (size_t l = 0; l < kLanes; ++l) sum += lanes[l];
  for (; j_sum < end; ++j_sum) sum += s[j_sum];
  return sum;
}

}  // namespace

namespace detail {

double ssim_unchecked(const io::Image& reference, const io::Image& test) {
  const int w = reference.width, h = reference.height;
  if (w < kTaps || h < kTaps)
    throw InputError(fmt::format(
        "SSIM: the images are {}x{}; the 11x11 Gaussian window needs at least 11x11", w, h));
  static const std::array<double, kTaps> window = gaussian_window();
  const size_t row_len = size_t(w);
  // Each task converts the rows its window reaches into a ring of 11 rows per image, so no
  // full-size copy of the images is ever made.
  struct Scratch {
    std::vector<double> ring_x, ring_y, work;
  };
  tbb::enumerable_thread_specific<Scratch> scratch([row_len] {
    return Scratch{std::vector<double>(kTaps * row_len), std::vector<double>(kTaps * row_len),
                   std::vector<double>(6 * row_len)};
  });
  const int first = kRadius, last = h - kRadius;  // output rows
  constexpr int kBlock = 64;
  const int blocks = (last - first + kBlock - 1) / kBlock;
  double total = 0;
  for (int c = 0; c < 3; ++c) {
    std::vector<double> row_sums(size_t(last - first));
    tbb::parallel_for(0, blocks, [&](int block) {
      Scratch& s = scratch.local();
      const int y0 = first + block * kBlock, y1 = std::min(last, y0 + kBlock);
      auto slot = [&](std::vector<double>& ring, int row) {
        return ring.data() + size_t(row % kTaps) * row_len;
      };
      for (int row = y0 - kRadius; row < y0 + kRadius; ++row) {
        convert_row(reference, row, c, Values::display, slot(s.ring_x, row));
        convert_row(test, row, c, Values::display, slot(s.ring_y, row));
      }
      for (int y = y0; y < y1; ++y) {
        convert_row(reference, y + kRadius, c, Values::display, slot(s.ring_x, y + kRadius));
        convert_row(test, y + kRadius, c, Values::display, slot(s.ring_y, y + kRadius));
        const double* xr[kTaps];
        const double* yr[kTaps];
        for (int t = 0; t < kTaps; ++t) {
          xr[t] = slot(s.ring_x, y - kRadius + t);
          yr[t] = slot(s.ring_y, y - kRadius + t);
        }
        row_sums[size_t(y - first)] = ssim_row(xr, yr, w, window.data(), s.work.data());
      }
    });
    double sum = 0;
    for (double v : row_sums) sum += v;  // in row order: reproducible
    total += sum / (double(w - 2 * kRadius) * double(h - 2 * kRadius));
  }
  return total / 3.0;
}

}  // namespace detail

double ssim(const io::Image& reference, const io::Image& test) {
  detail::check_pair(reference, test, "SSIM");
  return detail::ssim_unchecked(reference, test);
}

}  // namespace pb::metrics

namespace pb::metrics::detail {

// The expected SSIM of the true image T against a noisy reference R (noise_floor.h), from R's own
// windowed statistics and those of its noise, on display values like SSIM itself. With x = D(R),
// y = D(T) and x = y + n, the window moments SSIM uses (eq. 13) are, in expectation over n:
//   uy = ux - m              (m: the window mean of n, E m^2 = Var of the windowed noise mean)
//   vy = vx - noise          (noise: what n adds to the windowed variance, correlation included)
//   vxy = vy                 (n is independent of T)
// Both noise terms come from the half-difference field d = (D(H1) - D(H2)) / 2, whose covariance is
// n's: E[ud^2] = E m^2 and E[vd] = E[noise] (ud, vd: d's window mean and variance), so
//   SSIM floor per window = (1 - ud^2 / (2 ux^2 + C1)) (2 vy + C2) / (vx + vy + C2),
//   vy = max(0, vx - vd),
// averaged as ssim() averages its map. (SSIM of R against R +- d would count the noise present in
// both arguments as shared structure: in a flat noisy region it gives about 2/3 where the truth
// scores C2 / (noise + C2).)
double ssim_of_truth(const io::Image& mean, const io::Image& half_a, const io::Image& half_b) {
  const int w = mean.width, h = mean.height;
  if (w < kTaps || h < kTaps)
    throw InputError(fmt::format(
        "SSIM: the images are {}x{}; the 11x11 Gaussian window needs at least 11x11", w, h));
  static const std::array<double, kTaps> window = gaussian_window();
  const size_t n = size_t(w) * size_t(h);
  // Planes x, x^2, d, d^2, then their vertical and horizontal window sums.
  std::vector<double> planes(4 * n), vertical(4 * n);
  double total = 0;
  for (int c = 0; c < 3; ++c) {
    tbb::parallel_for(0, h, [&](int y) {
      std::vector<double> a(size_t(w) * 2);
      double* x = planes.data() + size_t(y) * size_t(w);
      convert_row(mean, y, c, Values::display, x);
      convert_row(half_a, y, c, Values::display, a.data());
      convert_row(half_b, y, c, Values::display, a.data() + w);
      for (int i = 0; i < w; ++i) {
        const size_t p = size_t(y) * size_t(w) + size_t(i);
        const double d = 0.5 * (a[size_t(i)] - a[size_t(w + i)]);
        planes[n + p] = x[i] * x[i];
        planes[2 * n + p] = d;
        planes[3 * n + p] = d * d;
      }
    });
    tbb::parallel_for(kRadius, h - kRadius, [&](int y) {
      for (size_t q = 0; q < 4; ++q)
        for (int i = 0; i < w; ++i) {
          double s = 0;
          for (int t = 0; t < kTaps; ++t)
            s +=
                window[size_t(t)] * planes[q * n + size_t(y + t - kRadius) * size_t(w) + size_t(i)];
          vertical[q * n + size_t(y) * size_t(w) + size_t(i)] = s;
        }
    });
    std::vector<double> row_sums(static_cast<size_t>(h));
    tbb::parallel_for(kRadius, h - kRadius, [&](int y) {
      double sum = 0;
      for (int i = kRadius; i < w - kRadius; ++i) {
        double u[4] = {0, 0, 0, 0};
        for (size_t q = 0; q < 4; ++q)
          for (int t = 0; t < kTaps; ++t)
            u[q] += window[size_t(t)] *
                    vertical[q * n + size_t(y) * size_t(w) + size_t(i + t - kRadius)];
        const double ux = u[0], vx = u[1] - ux * ux, ud = u[2], vd = u[3] - ud * ud;
        const double vy = std::max(0.0, vx - vd);
        const double luminance = 1.0 - ud * ud / (2 * ux * ux + kC1);
        sum += luminance * (2 * vy + kC2) / (vx + vy + kC2);
      }
      row_sums[size_t(y)] = sum;
    });
    double sum = 0;
    for (double v : row_sums) sum += v;  // in row order: reproducible
    total += sum / (double(w - 2 * kRadius) * double(h - 2 * kRadius));
  }
  return total / 3.0;
}

}  // namespace pb::metrics::detail
