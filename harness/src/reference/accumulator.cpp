#include "reference/accumulator.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "reference/path_class.h"
#include "reference/path_space.h"

namespace pb::trace::detail {

Accumulator::Accumulator(size_t pixels, uint32_t class_mask) : pixels_(pixels) {
  for (int c = 0; c < kPathClassCount; ++c)
    if (class_mask & (1u << c)) classes_.push_back(c);
  moments_.resize(pixels * classes_.size());
}

void Accumulator::add(uint32_t iteration, const std::vector<glm::vec3>& frame,
                      tbb::task_arena& arena) {
  bool odd = iteration % 2 == 1;
  size_t k = classes_.size();
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, pixels_, 1024),
                      [&](const tbb::blocked_range<size_t>& r) {
                        for (size_t i = r.begin(); i != r.end(); ++i) {
                          const glm::vec3* f = &frame[i * kClasses];
                          // The classes' sum in float (one conversion, not five): an
                          // iteration's image is float, its rounding far below the noise.
                          glm::vec3 combined = f[0];
                          for (int q = 1; q < kClasses; ++q) combined += f[q];
                          for (size_t j = 0; j < k; ++j) {
                            int c = classes_[j];
                            const glm::dvec3 v(c == int(PathClass::combined) ? combined : f[c]);
                            Moments& m = moments_[i * k + j];
                            m.sum += v;
                            m.sum2 += v * v;
                            if (odd) m.odd += v;
                            double l = luminance(glm::vec3(v));
                            m.lum2 += l * l;
                          }
                        }
                      });
  });
  ++iterations_;
}

double Accumulator::rel_error() const {
  if (iterations_ < 2) return 0;
  double n = iterations_, acc = 0;
  size_t k = classes_.size(), counted = 0;
  for (size_t j = 0; j < k; ++j) {
    double mean_lum = 0;
    for (size_t i = 0; i < pixels_; ++i) mean_lum += luminance(glm::vec3(moments_[i * k + j].sum));
    mean_lum /= n * double(pixels_);
    if (!(mean_lum > 0)) continue;
    double floor2 = std::pow(0.01 * mean_lum, 2.0);
    for (size_t i = 0; i < pixels_; ++i) {
      const Moments& m = moments_[i * k + j];
      double mean = luminance(glm::vec3(m.sum)) / n;
      double var_of_mean = std::max(0.0, m.lum2 - n * mean * mean) / (n * (n - 1));
      acc += var_of_mean / (mean * mean + floor2);
    }
    ++counted;
  }
  return counted ? std::sqrt(acc / double(counted * pixels_)) : 0.0;
}

void Accumulator::resolve(size_t j, int width, int height, io::Image& mean_image,
                          io::Image& variance_image, std::array<io::Image, 2>& half) const {
  mean_image = io::Image(width, height, 3);
  variance_image = io::Image(width, height, 3);
  half[0] = io::Image(width, height, 3);
  half[1] = io::Image(width, height, 3);
  double n = iterations_;
  double n_odd = iterations_ / 2, n_even = iterations_ - iterations_ / 2;
  size_t k = classes_.size();
  for (size_t i = 0; i < pixels_; ++i) {
    const Moments& m = moments_[i * k + j];
    for (int ch = 0; ch < 3; ++ch) {
      double mean = n > 0 ? m.sum[ch] / n : 0.0;
      double var = n > 1 ? std::max(0.0, m.sum2[ch] - n * mean * mean) / (n * (n - 1)) : 0.0;
      mean_image.pixels[i * 3 + ch] = float(mean);
      variance_image.pixels[i * 3 + ch] = float(var);
      half[0].pixels[i * 3 + ch] = n_even > 0 ? float((m.sum[ch] - m.odd[ch]) / n_even) : 0.f;
      half[1].pixels[i * 3 + ch] = n_odd > 0 ? float(m.odd[ch] / n_odd) : 0.f;
    }
  }
}

}  // namespace pb::trace::detail
