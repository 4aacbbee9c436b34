#include "metrics/flicker.h"

#include <fmt/format.h>

#include <cmath>

#include "metrics/detail.h"
#include "photonbench/error.h"

namespace pb::metrics {

namespace {

void check_same_size(const io::Image& first, const io::Image& image, const char* what) {
  if (image.width != first.width || image.height != first.height)
    throw InputError(fmt::format("flicker: {} is {}x{}, the current reference {}x{}", what,
                                 image.width, image.height, first.width, first.height));
  if (!image.linear) throw InputError(fmt::format("flicker: {} is not a linear image", what));
}

}  // namespace

Flicker flicker(const NoisyReference& previous, const NoisyReference& current,
                const io::Image& test_previous, const io::Image& test_current) {
  const io::Image& r_c = current.mean;
  check_same_size(r_c, r_c, "the current reference");
  check_same_size(r_c, previous.mean, "the previous reference");
  check_same_size(r_c, previous.half_a, "the previous reference's first half");
  check_same_size(r_c, previous.half_b, "the previous reference's second half");
  check_same_size(r_c, current.half_a, "the current reference's first half");
  check_same_size(r_c, current.half_b, "the current reference's second half");
  detail::check_pair(previous.mean, test_previous, "flicker, previous frame");
  detail::check_pair(r_c, test_current, "flicker, current frame");
  const size_t w = size_t(r_c.width);
  // Per row: sums of the squared difference errors, of the squared differences of the references'
  // noise samples, and of the squared mean levels.
  struct Sums {
    double error = 0, noise = 0, level = 0;
  };
  std::vector<Sums> rows(size_t(r_c.height));
  detail::sum_rows(0, r_c.height, [&](int y) {
    std::vector<double> tp(w), tc(w), rp(w), rc(w), ap(w), bp(w), ac(w), bc(w);
    Sums& s = rows[size_t(y)];
    for (int ch = 0; ch < 3; ++ch) {
      detail::convert_row(test_previous, y, ch, detail::Values::linear, tp.data());
      detail::convert_row(test_current, y, ch, detail::Values::linear, tc.data());
      detail::convert_row(previous.mean, y, ch, detail::Values::linear, rp.data());
      detail::convert_row(r_c, y, ch, detail::Values::linear, rc.data());
      detail::convert_row(previous.half_a, y, ch, detail::Values::linear, ap.data());
      detail::convert_row(previous.half_b, y, ch, detail::Values::linear, bp.data());
      detail::convert_row(current.half_a, y, ch, detail::Values::linear, ac.data());
      detail::convert_row(current.half_b, y, ch, detail::Values::linear, bc.data());
      for (size_t x = 0; x < w; ++x) {
        const double e = (tc[x] - tp[x]) - (rc[x] - rp[x]);
        const double level = 0.5 * (rc[x] + rp[x]);
        s.error += e * e;
        const double noise = 0.5 * (ac[x] - bc[x]) - 0.5 * (ap[x] - bp[x]);
        s.noise += noise * noise;
        s.level += level * level;
      }
    }
    return 0.0;
  });
  Sums total;  // in row order: the same bits whatever the schedule
  for (const Sums& s : rows) {
    total.error += s.error;
    total.noise += s.noise;
    total.level += s.level;
  }
  if (!(total.level > 0))
    throw InputError("flicker: the references are black everywhere; no relative change exists");
  const double rms_level = std::sqrt(total.level);
  return {std::sqrt(total.error) / rms_level, std::sqrt(total.noise) / rms_level};
}

}  // namespace pb::metrics
