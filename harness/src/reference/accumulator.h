// The reference renderer's accumulation over iterations (reference.h): per pixel and requested
// class, the moments of the independent iteration images, from which come the mean, the variance
// of the mean, the even and odd halves, and the error estimate of the rel_error stop rule.
// Internal to reference/.
#pragma once

#include <tbb/task_arena.h>

#include <array>
#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "io/image.h"

namespace pb::trace::detail {

class Accumulator {
 public:
  // The classes of `class_mask` (class_bit(...) | ...) over `pixels` pixels.
  Accumulator(size_t pixels, uint32_t class_mask);
  // Adds iteration `iteration` (0-based) from frame[pixel * kClasses + class].
  void add(uint32_t iteration, const std::vector<glm::vec3>& frame, tbb::task_arena& arena);
  uint32_t iterations() const { return iterations_; }
  // reference.h's error estimate over the requested classes; 0 before two iterations.
  double rel_error() const;
  // Mean, variance of the mean and the even/odd halves of class slot j (classes()[j]).
  void resolve(size_t j, int width, int height, io::Image& mean, io::Image& variance,
               std::array<io::Image, 2>& half) const;
  const std::vector<int>& classes() const { return classes_; }

 private:
  // Per pixel and requested class: sums over iterations of the iteration image, of its square, of
  // the odd iterations' images, and of the squared luminance (for the error estimate).
  struct Moments {
    glm::dvec3 sum{0.0}, sum2{0.0}, odd{0.0};
    double lum2 = 0;
  };
  size_t pixels_;
  std::vector<int> classes_;
  std::vector<Moments> moments_;
  uint32_t iterations_ = 0;
};

}  // namespace pb::trace::detail
