// PSNR, RMSE, MAE, relMSE, temporal instability, and evaluate() which scores one pair with every
// metric while converting each image once.
#include <fmt/format.h>
#include <tbb/enumerable_thread_specific.h>

#include <cmath>
#include <utility>

#include "metrics/detail.h"
#include "metrics/metrics.h"
#include "photonbench/error.h"

namespace pb::metrics {
namespace {

using detail::sum_rows;
using detail::Values;

// Mean over pixels and the three colour channels of term(reference value, test value), on the
// given values, converting one row at a time.
template <typename Term>
double mean_over_channels(const io::Image& r, const io::Image& t, Values values, const Term& term) {
  const size_t w = size_t(r.width);
  tbb::enumerable_thread_specific<std::vector<double>> rows(
      [w] { return std::vector<double>(2 * w); });
  const double sum = sum_rows(0, r.height, [&](int y) {
    std::vector<double>& buf = rows.local();
    double* a = buf.data();
    double* b = buf.data() + w;
    double s = 0;
    for (int c = 0; c < 3; ++c) {
      detail::convert_row(r, y, c, values, a);
      detail::convert_row(t, y, c, values, b);
      for (size_t x = 0; x < w; ++x) s += term(a[x], b[x]);
    }
    return s;
  });
  return sum / (3.0 * double(r.width) * double(r.height));
}

double squared_error(double a, double b) { return (b - a) * (b - a); }

// scikit-image's peak_signal_noise_ratio with data_range = 1: 10 log10(1 / MSE).
Psnr psnr_unchecked(const io::Image& r, const io::Image& t) {
  const double mse = mean_over_channels(r, t, Values::display, squared_error);
  Psnr p;
  p.identical = mse == 0.0;
  if (!p.identical) p.db = 10.0 * std::log10(1.0 / mse);
  return p;
}

double rmse_unchecked(const io::Image& r, const io::Image& t) {
  return std::sqrt(mean_over_channels(r, t, Values::linear, squared_error));
}

double mae_unchecked(const io::Image& r, const io::Image& t) {
  return mean_over_channels(r, t, Values::linear,
                            [](double a, double b) { return detail::abs_d(b - a); });
}

// Relative MSE as rendering papers use it (e.g. Rousselle et al. 2011): the squared error over the
// squared reference, with 0.01 keeping dark pixels from dominating.
double relmse_unchecked(const io::Image& r, const io::Image& t) {
  return mean_over_channels(r, t, Values::linear,
                            [](double a, double b) { return (b - a) * (b - a) / (a * a + 0.01); });
}

// Rec. 709 luma of the display-encoded colour channels, one value per pixel.
std::vector<double> display_luma(const io::Image& frame) {
  const size_t w = size_t(frame.width);
  std::vector<double> luma(frame.pixel_count());
  tbb::parallel_for(0, frame.height, [&](int y) {
    std::vector<double> row(w);
    double* out = luma.data() + size_t(y) * w;
    const double weights[3] = {0.2126, 0.7152, 0.0722};
    for (int c = 0; c < 3; ++c) {
      detail::convert_row(frame, y, c, Values::display, row.data());
      for (size_t x = 0; x < w; ++x) out[x] = (c == 0 ? 0.0 : out[x]) + weights[c] * row[x];
    }
  });
  return luma;
}

}  // namespace

Psnr psnr(const io::Image& reference, const io::Image& test) {
  detail::check_pair(reference, test, "PSNR");
  return psnr_unchecked(reference, test);
}

double rmse(const io::Image& reference, const io::Image& test) {
  detail::check_pair(reference, test, "RMSE");
  return rmse_unchecked(reference, test);
}

double mae(const io::Image& reference, const io::Image& test) {
  detail::check_pair(reference, test, "MAE");
  return mae_unchecked(reference, test);
}

double relmse(const io::Image& reference, const io::Image& test) {
  detail::check_pair(reference, test, "relMSE");
  return relmse_unchecked(reference, test);
}

Scores evaluate(const io::Image& reference, const io::Image& test, const FlipOptions& options,
                io::Image* flip_error_map) {
  detail::check_pair(reference, test, "metrics");
  Scores s;
  FlipResult f = flip(reference, test, options);
  s.flip = f.stats;
  if (flip_error_map) *flip_error_map = std::move(f.error_map);
  s.ssim = detail::ssim_unchecked(reference, test);
  const Psnr p = psnr_unchecked(reference, test);
  s.psnr = p.db;
  s.identical = p.identical;
  s.rmse = rmse_unchecked(reference, test);
  s.mae = mae_unchecked(reference, test);
  s.relmse = relmse_unchecked(reference, test);
  return s;
}

double temporal_instability(const std::vector<io::Image>& reference_frames,
                            const std::vector<io::Image>& test_frames) {
  if (reference_frames.size() != test_frames.size())
    throw InputError(fmt::format("temporal instability: {} reference frames but {} test frames",
                                 reference_frames.size(), test_frames.size()));
  if (reference_frames.size() < 2)
    throw InputError(fmt::format("temporal instability needs two or more frames, not {}",
                                 reference_frames.size()));
  const io::Image& first = reference_frames.front();
  for (size_t i = 0; i < reference_frames.size(); ++i) {
    detail::check_pair(reference_frames[i], test_frames[i],
                       fmt::format("temporal instability, frame {}", i));
    if (reference_frames[i].width != first.width || reference_frames[i].height != first.height)
      throw InputError(fmt::format("temporal instability: frame {} is {}x{}, frame 0 is {}x{}", i,
                                   reference_frames[i].width, reference_frames[i].height,
                                   first.width, first.height));
  }
  std::vector<double> prev_r = display_luma(reference_frames[0]);
  std::vector<double> prev_t = display_luma(test_frames[0]);
  const size_t w = size_t(first.width);
  double total = 0;
  for (size_t i = 1; i < reference_frames.size(); ++i) {
    std::vector<double> cur_r = display_luma(reference_frames[i]);
    std::vector<double> cur_t = display_luma(test_frames[i]);
    total += sum_rows(0, first.height, [&](int y) {
      double s = 0;
      for (size_t x = size_t(y) * w, end = x + w; x < end; ++x)
        s += detail::abs_d((cur_t[x] - prev_t[x]) - (cur_r[x] - prev_r[x]));
      return s;
    });
    prev_r = std::move(cur_r);
    prev_t = std::move(cur_t);
  }
  return total / (double(reference_frames.size() - 1) * double(first.pixel_count()));
}

}  // namespace pb::metrics
