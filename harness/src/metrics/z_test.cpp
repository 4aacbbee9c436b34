#include "metrics/z_test.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "metrics/detail.h"
#include "photonbench/error.h"

namespace pb::metrics {

ZTestResult z_test(const io::Image& mean_a, const io::Image& var_a, const io::Image& mean_b,
                   const io::Image& var_b, double alpha) {
  if (!(alpha > 0 && alpha < 1))
    throw InputError(fmt::format("z-test: alpha {} is not in (0, 1)", alpha));
  detail::check_pair(mean_a, mean_b, "z-test, means");
  detail::check_pair(mean_a, var_a, "z-test, first variance");
  detail::check_pair(mean_b, var_b, "z-test, second variance");
  const size_t w = size_t(mean_a.width);
  const size_t n = 3 * mean_a.pixel_count();
  ZTestResult out;
  out.alpha = alpha;
  out.tested = n;
  // 1 - (1 - alpha)^(1/n), through log1p/expm1: for large n the direct form loses every digit.
  out.sidak_level = -std::expm1(std::log1p(-alpha) / double(n));
  std::vector<double> a(w), b(w), va(w), vb(w);
  for (int y = 0; y < mean_a.height; ++y)
    for (int c = 0; c < 3; ++c) {
      detail::convert_row(mean_a, y, c, detail::Values::linear, a.data());
      detail::convert_row(mean_b, y, c, detail::Values::linear, b.data());
      detail::convert_row(var_a, y, c, detail::Values::linear, va.data());
      detail::convert_row(var_b, y, c, detail::Values::linear, vb.data());
      for (size_t x = 0; x < w; ++x) {
        if (va[x] < 0 || vb[x] < 0)
          throw InputError(fmt::format("z-test: negative variance at pixel ({}, {})", x, y));
        const double diff = a[x] - b[x], var = va[x] + vb[x];
        double p;
        if (var > 0) {
          p = std::erfc(std::abs(diff) / std::sqrt(2 * var));
        } else {
          ++out.exact;
          p = diff == 0 ? 1.0 : 0.0;
          out.exact_mismatches += diff != 0;
        }
        out.min_p = std::min(out.min_p, p);
        out.rejected += p < out.sidak_level;
      }
    }
  out.p_value = -std::expm1(double(n) * std::log1p(-out.min_p));
  return out;
}

}  // namespace pb::metrics
