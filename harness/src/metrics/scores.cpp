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

// Converts both images row by row and returns the sum over rows of row_sum(a, b, width), a and b
// the reference's and test's values of one colour channel of one row, over all three channels.
template <typename RowSum>
auto sum_over_channels(const io::Image& r, const io::Image& t, Values values,
                       const RowSum& row_sum) {
  const size_t w = size_t(r.width);
  tbb::enumerable_thread_specific<std::vector<double>> rows(
      [w] { return std::vector<double>(2 * w); });
  using Sum = decltype(row_sum(nullptr, nullptr, w));
  std::vector<Sum> per_row(size_t(r.height));
  tbb::parallel_for(0, r.height, [&](int y) {
    std::vector<double>& buf = rows.local();
    double* a = buf.data();
    double* b = buf.data() + w;
    Sum s{};
    for (int c = 0; c < 3; ++c) {
      detail::convert_row(r, y, c, values, a);
      detail::convert_row(t, y, c, values, b);
      s += row_sum(a, b, w);
    }
    per_row[size_t(y)] = s;
  });
  Sum total{};
  for (const Sum& s : per_row) total += s;  // in row order: reproducible
  return total;
}

// Sums of the squared, absolute and relative squared errors, vectorisable per row.
struct ErrorSums {
  double squared = 0, absolute = 0, relative = 0;
  ErrorSums& operator+=(const ErrorSums& o) {
    squared += o.squared;
    absolute += o.absolute;
    relative += o.relative;
    return *this;
  }
};

// The per-row error sums are kernels of every level (detail::dispatch), so use_vector_path
// switches them as it does SSIM's and FLIP's. Each keeps Isa::lanes partial sums in a vector: the
// compiler may not reorder a floating-point sum, so a plain loop is one serial chain of additions
// whatever the level. The lanes are added in a fixed order after the row, so a level's result does
// not depend on the data's alignment; levels differ by rounding.
struct SquaredErrorRow {
  template <class Isa>
  [[gnu::always_inline]] static double run(const double* a, const double* b, size_t n) {
    using V = detail::DoublesOf<Isa>;
    constexpr size_t kLanes = Isa::lanes;
    V acc{};
    size_t x = 0;
    for (; x + kLanes <= n; x += kLanes) {
      const V d = detail::load<V>(b + x) - detail::load<V>(a + x);
      acc += d * d;
    }
    double s = 0;
    for (size_t l = 0; l < kLanes; ++l) s += acc[l];
    for (; x < n; ++x) s += (b[x] - a[x]) * (b[x] - a[x]);
    return s;
  }
};

struct ErrorSumsRow {
  template <class Isa>
  [[gnu::always_inline]] static ErrorSums run(const double* a, const double* b, size_t n) {
    using V = detail::DoublesOf<Isa>;
    constexpr size_t kLanes = Isa::lanes;
    V squared{}, absolute{}, relative{};
    size_t x = 0;
    for (; x + kLanes <= n; x += kLanes) {
      const V r = detail::load<V>(a + x);
      const V d = detail::load<V>(b + x) - r;
      squared += d * d;
      absolute += d < 0 ? -d : d;
      // Relative MSE as rendering papers use it (e.g. Rousselle et al. 2011): the squared error
      // over the squared reference, with 0.01 keeping dark pixels from dominating.
      relative += d * d / (r * r + 0.01);
    }
    ErrorSums s;
    for (size_t l = 0; l < kLanes; ++l)
      s.squared += squared[l], s.absolute += absolute[l], s.relative += relative[l];
    for (; x < n; ++x) {
      const double d = b[x] - a[x];
      s.squared += d * d;
      s.absolute += detail::abs_d(d);
      s.relative += d * d / (a[x] * a[x] + 0.01);
    }
    return s;
  }
};

double squared_error_row(const double* a, const double* b, size_t n) {
  return detail::dispatch<SquaredErrorRow>(a, b, n);
}

ErrorSums error_sums_row(const double* a, const double* b, size_t n) {
  return detail::dispatch<ErrorSumsRow>(a, b, n);
}

double values_per_image(const io::Image& r) { return 3.0 * double(r.width) * double(r.height); }

// scikit-image's peak_signal_noise_ratio with data_range = 1: 10 log10(1 / MSE).
Psnr psnr_unchecked(const io::Image& r, const io::Image& t) {
  const double mse =
      sum_over_channels(r, t, Values::display, squared_error_row) / values_per_image(r);
  Psnr p;
  p.identical = mse == 0.0;
  if (!p.identical) p.db = 10.0 * std::log10(1.0 / mse);
  return p;
}

// Mean squared, absolute and relative squared error on linear values.
ErrorSums linear_errors(const io::Image& r, const io::Image& t) {
  ErrorSums s = sum_over_channels(r, t, Values::linear, error_sums_row);
  const double n = values_per_image(r);
  return {s.squared / n, s.absolute / n, s.relative / n};
}

// Rec. 709 luma of the display-encoded colour channels of row y; channel is scratch of width.
void display_luma_row(const io::Image& frame, int y, double* luma, double* channel) {
  const size_t w = size_t(frame.width);
  const double weights[3] = {0.2126, 0.7152, 0.0722};
  for (int c = 0; c < 3; ++c) {
    detail::convert_row(frame, y, c, Values::display, channel);
    for (size_t x = 0; x < w; ++x) luma[x] = (c == 0 ? 0.0 : luma[x]) + weights[c] * channel[x];
  }
}

}  // namespace

Psnr psnr(const io::Image& reference, const io::Image& test) {
  detail::check_pair(reference, test, "PSNR");
  return psnr_unchecked(reference, test);
}

double rmse(const io::Image& reference, const io::Image& test) {
  detail::check_pair(reference, test, "RMSE");
  return std::sqrt(linear_errors(reference, test).squared);
}

double mae(const io::Image& reference, const io::Image& test) {
  detail::check_pair(reference, test, "MAE");
  return linear_errors(reference, test).absolute;
}

double relmse(const io::Image& reference, const io::Image& test) {
  detail::check_pair(reference, test, "relMSE");
  return linear_errors(reference, test).relative;
}

Scores evaluate(const io::Image& reference, const io::Image& test, const FlipOptions& options,
                io::Image* flip_error_map, const MetricSelection& selection) {
  detail::check_pair(reference, test, "metrics");
  Scores s;
  if (selection.flip) {
    FlipResult f = flip(reference, test, options);
    s.flip = f.stats;
    if (flip_error_map) *flip_error_map = std::move(f.error_map);
  }
  s.ssim = detail::ssim_unchecked(reference, test);
  const Psnr p = psnr_unchecked(reference, test);
  s.psnr = p.db;
  s.identical = p.identical;
  const ErrorSums e = linear_errors(reference, test);
  s.rmse = std::sqrt(e.squared);
  s.mae = e.absolute;
  s.relmse = e.relative;
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
  // Row by row through all frames, so only a few rows of luma exist at a time.
  const size_t w = size_t(first.width);
  tbb::enumerable_thread_specific<std::vector<double>> scratch(
      [w] { return std::vector<double>(5 * w); });
  const double total = sum_rows(0, first.height, [&](int y) {
    std::vector<double>& buf = scratch.local();
    double* prev_r = buf.data();
    double* prev_t = prev_r + w;
    double* cur_r = prev_t + w;
    double* cur_t = cur_r + w;
    double* channel = cur_t + w;
    display_luma_row(reference_frames[0], y, prev_r, channel);
    display_luma_row(test_frames[0], y, prev_t, channel);
    double s = 0;
    for (size_t i = 1; i < reference_frames.size(); ++i) {
      display_luma_row(reference_frames[i], y, cur_r, channel);
      display_luma_row(test_frames[i], y, cur_t, channel);
      for (size_t x = 0; x < w; ++x)
        s += detail::abs_d((cur_t[x] - prev_t[x]) - (cur_r[x] - prev_r[x]));
      std::swap(prev_r, cur_r);
      std::swap(prev_t, cur_t);
    }
    return s;
  });
  return total / (double(reference_frames.size() - 1) * double(first.pixel_count()));
}

}  // namespace pb::metrics
