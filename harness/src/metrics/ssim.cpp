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

using detail::dispatch;
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

// Rows hold the image's width rounded up to 8 (the widest vector) plus 16 zeros, so every vector
// loop runs whole vectors: the zero columns give finite moments that no output column reads, and
// the last vector's lanes past the row are masked out of the sum.
size_t padded_width(int width) { return (size_t(width) + 7) / 8 * 8 + 16; }

// Sum of the SSIM map over one output row and the columns [kRadius, width - kRadius), from the
// 11 input rows around it (xr, yr, padded as above). moments holds 5 padded rows.
//
// The window is symmetric (k[t] == k[10 - t]), so each pass adds the rows (or columns) t and 10 - t
// before weighting them: 6 multiply-adds per moment instead of 11. Vertical first, 5 moments per
// column, Isa::lanes columns a vector; then horizontal, Isa::lanes output columns a vector (lanes
// along the row), with the SSIM map (Wang et al. eq. 13) on the moments still in registers.
struct SsimRow {
  template <class Isa>
  [[gnu::always_inline]] static double run(const double* const* xr, const double* const* yr,
                                           int width, const double* k, double* moments) {
    using V = detail::DoublesOf<Isa>;
    constexpr int kLanes = Isa::lanes;
    const size_t stride = padded_width(width);
    double* __restrict mx = moments;
    double* __restrict my = moments + stride;
    double* __restrict mxx = moments + 2 * stride;
    double* __restrict myy = moments + 3 * stride;
    double* __restrict mxy = moments + 4 * stride;
    const size_t out_columns = size_t(width - 2 * kRadius);
    // The horizontal pass reads columns up to round_up(out_columns, lanes) + 2 kRadius - 1.
    const size_t out_end = (out_columns + kLanes - 1) / kLanes * kLanes;
    const size_t in_end = out_end + 2 * kRadius;
    V weight[kRadius + 1];
    for (int t = 0; t <= kRadius; ++t) weight[t] = V{} + k[t];
    for (size_t j = 0; j < in_end; j += kLanes) {
      const V a = detail::load<V>(xr[kRadius] + j), b = detail::load<V>(yr[kRadius] + j);
      const V w = weight[kRadius];
      V sx = w * a, sy = w * b, sxx = w * (a * a), syy = w * (b * b), sxy = w * (a * b);
      for (int t = 0; t < kRadius; ++t) {
        const V a0 = detail::load<V>(xr[t] + j), a1 = detail::load<V>(xr[2 * kRadius - t] + j);
        const V b0 = detail::load<V>(yr[t] + j), b1 = detail::load<V>(yr[2 * kRadius - t] + j);
        const V wt = weight[t];
        sx = detail::madd<Isa>(wt, a0 + a1, sx);
        sy = detail::madd<Isa>(wt, b0 + b1, sy);
        sxx = detail::madd<Isa>(wt, detail::madd<Isa>(a0, a0, a1 * a1), sxx);
        syy = detail::madd<Isa>(wt, detail::madd<Isa>(b0, b0, b1 * b1), syy);
        sxy = detail::madd<Isa>(wt, detail::madd<Isa>(a0, b0, a1 * b1), sxy);
      }
      detail::store(mx + j, sx);
      detail::store(my + j, sy);
      detail::store(mxx + j, sxx);
      detail::store(myy + j, syy);
      detail::store(mxy + j, sxy);
    }
    // Lane l of the last vector is output column out_end - lanes + l: counted when below
    // out_columns.
    V last_mask;
    for (int l = 0; l < kLanes; ++l) last_mask[l] = out_end - kLanes + size_t(l) < out_columns;
    V sums = {};
    for (size_t j = 0; j < out_end; j += kLanes) {
      auto horizontal = [&](const double* m) __attribute__((always_inline)) {
        V u = weight[kRadius] * detail::load<V>(m + j + kRadius);
        for (int t = 0; t < kRadius; ++t)
          u = detail::madd<Isa>(
              weight[t], detail::load<V>(m + j + t) + detail::load<V>(m + j + 2 * kRadius - t), u);
        return u;
      };
      const V ux = horizontal(mx), uy = horizontal(my);
      const V uxx = horizontal(mxx), uyy = horizontal(myy), uxy = horizontal(mxy);
      const V vx = uxx - ux * ux, vy = uyy - uy * uy, vxy = uxy - ux * uy;
      const V a1 = 2 * ux * uy + kC1, a2 = 2 * vxy + kC2;
      const V b1 = ux * ux + uy * uy + kC1, b2 = vx + vy + kC2;
      const V map = (a1 * a2) / (b1 * b2);
      sums += j + kLanes < out_end ? map : map * last_mask;
    }
    // The lanes in order: a fixed order for a given width and build, so results are reproducible
    // whatever the threads or the alignment.
    double sum = 0;
    for (int l = 0; l < kLanes; ++l) sum += sums[l];
    return sum;
  }
};

}  // namespace

namespace detail {

double ssim_unchecked(const io::Image& reference, const io::Image& test) {
  const int w = reference.width, h = reference.height;
  if (w < kTaps || h < kTaps)
    throw InputError(fmt::format(
        "SSIM: the images are {}x{}; the 11x11 Gaussian window needs at least 11x11", w, h));
  static const std::array<double, kTaps> window = gaussian_window();
  const size_t row_len = padded_width(w);
  // Each task converts the rows its window reaches into a ring of 11 rows per image, so no
  // full-size copy of the images is ever made. The rows' padding stays zero (convert_row writes
  // the first w values).
  struct Scratch {
    std::vector<double> ring_x, ring_y, moments;
  };
  tbb::enumerable_thread_specific<Scratch> scratch([row_len] {
    return Scratch{std::vector<double>(kTaps * row_len), std::vector<double>(kTaps * row_len),
                   std::vector<double>(5 * row_len)};
  });
  const int first = kRadius, last = h - kRadius;  // output rows
  constexpr int kBlock = 64;
  const int blocks = (last - first + kBlock - 1) / kBlock;
  // Channels and row blocks in one loop, so the threads never wait at a channel's end.
  std::vector<double> row_sums(3 * size_t(last - first));
  tbb::parallel_for(0, 3 * blocks, [&](int task) {
    const int c = task / blocks, block = task % blocks;
    Scratch& s = scratch.local();
    double* sums = row_sums.data() + size_t(c) * size_t(last - first);
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
      sums[size_t(y - first)] =
          dispatch<SsimRow>(&xr[0], &yr[0], w, window.data(), s.moments.data());
    }
  });
  double total = 0;
  for (int c = 0; c < 3; ++c) {
    double sum = 0;
    for (size_t i = 0; i < size_t(last - first); ++i)  // in row order: reproducible
      sum += row_sums[size_t(c) * size_t(last - first) + i];
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
