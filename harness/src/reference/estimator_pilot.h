// Estimator::automatic's pilot (estimators.h): which unbiased estimator renders a frame, path
// tracing or bidirectional path tracing, decided from the render's own first iterations. Internal
// to reference/.
#pragma once

#include <tbb/combinable.h>
#include <tbb/task_arena.h>

#include <array>
#include <cstdint>
#include <glm/glm.hpp>
#include <optional>
#include <vector>

#include "reference/bdpt.h"
#include "reference/estimators.h"
#include "reference/options.h"
#include "reference/path_space.h"

namespace pb::trace::detail {

// Estimator::automatic's pilot: on a grid of pixels, per requested class, the
// luminance moments of path tracing's, bidirectional path tracing's and photon mapping's estimates.
class Pilot {
 public:
  enum Part { path_tracing, bidirectional, splats, photons };
  Pilot(int width, int height, int stride, const std::vector<int>& classes);
  // One iteration of `part`, read from frame[pixel * kClasses + class] at the grid's pixels. The
  // render's frame holds path tracing's image and then, once photon mapping has added to it, the
  // sum of both: photon mapping's part is that sum less the path tracing image added last
  // (luminance is linear).
  void add(Part part, const std::vector<glm::vec3>& frame);
  uint32_t iterations(Part part) const { return iterations_[part]; }
  // The error estimate's square (reference.h) for one full-image iteration of path tracing or of
  // bidirectional path tracing, plus photon mapping, relative to the pixel means of both unbiased
  // estimators averaged plus photon mapping's (a short run of path tracing alone can miss the light
  // of a small bright region at many pixels, and dividing by its low mean there would inflate the
  // other estimator's relative variance). Light tracing's splats on the grid stand for stride^2
  // light paths each, so their variance is scaled by 1 / stride^2 to a full iteration's; path
  // tracing's and photon mapping's come from the render's own full iterations.
  double error2(bool bdpt) const;

 private:
  struct Moment {
    double s1 = 0, s2 = 0;
    void add(double v) { s1 += v, s2 += v * v; }
    double mean(uint32_t n) const { return n ? s1 / n : 0.0; }
    double variance(uint32_t n) const {
      return n > 1 ? std::max(0.0, s2 - s1 * s1 / n) / (n - 1) : 0.0;
    }
  };
  double variance(Part part, size_t slot) const;
  double mean(Part part, size_t slot) const { return moments_[part][slot].mean(iterations_[part]); }
  double mean(size_t p, size_t j) const;
  std::vector<int> classes_;
  int stride_;
  std::vector<size_t> pixels_;
  std::array<std::vector<Moment>, 4> moments_;
  std::array<uint32_t, 4> iterations_{};
  std::vector<double> last_path_tracing_;  // the grid's luminances of the last path tracing image
};

// The pilot's grid: every stride-th pixel in x and y, about 2000 pixels. (1000, which would halve
// the pilot's cost on short renders, picked path tracing on cornell-box in both rounds of
// bench_reference at 320x180: too few pixels see its hotspot's paths.)
int pilot_stride(size_t pixels);

// Estimator::automatic (estimators.h): the render starts as path tracing, and the pilot watches it.
// Path tracing's and photon mapping's iterations are the render's own (read at the grid's pixels),
// so they cost the pilot nothing and are kept when path tracing stays; beside each, one iteration
// of bidirectional path tracing on the grid of about 2000 pixels is the pilot's only extra work.
// After every iteration it predicts from the per-iteration variances and rays what reaching the
// target costs with either and decides:
//   * bidirectional path tracing, from kPilotMinIterations on, when predicted cheaper by
//     kPilotMargin than what path tracing has left to do (the render then restarts with it, so
//     the image is exactly its render; path tracing's iterations are dropped);
//   * path tracing when the pilot's next iteration would take its spending past kPilotBudget of
//     path tracing's predicted render, or after kPilotIterations: its cost scales with the render,
//     and where the render is short path tracing, the anchor, keeps it.
// A small bright region that path tracing finds by chance hides in a short pilot (its variance
// grows with the samples), so path tracing's prediction is low early on: the rule that stops the
// pilot early can only pick path tracing, whose cost is then the one predicted.
class EstimatorPilot {
 public:
  EstimatorPilot(const Rig& rig, const ReferenceOptions& options, const std::vector<int>& classes,
                 BdptPass& bdpt, tbb::task_arena& arena, tbb::combinable<uint64_t>& ray_count);

  // The render's image after its path tracing pass (path_tracing) or after photon mapping added
  // to it (photons), and the rays that pass traced.
  void observe(Pilot::Part part, const std::vector<glm::vec3>& frame, uint64_t rays);

  // After the render's iteration `done` (1-based): one bidirectional iteration on the grid where
  // it can still change the choice, then the decision; nothing while the pilot goes on.
  std::optional<Estimator> step(uint32_t done);

  PilotReport report() const;

 private:
  // Per-iteration error^2 and rays of each (photon mapping's in both), and the predicted cost of
  // reaching the target: iterations (error^2 falls as 1 / n) x rays per iteration.
  void predict(uint32_t done);
  // What path tracing has left to do after `done` iterations (to the target; for a render without
  // one, the cost of any given error has nothing left behind).
  double pt_left(uint32_t done, double pt_cost) const;
  // Whether bidirectional path tracing could be picked on what the pilot knows: its cost has a
  // floor whatever its variance (the error rule's least iterations, at its rays per iteration),
  // and while that floor is above what path tracing has left, its pilot iterations would buy
  // nothing (they resume if path tracing's prediction grows, as it does where it finds a bright
  // region by chance). Before its first iteration its rays are taken to be path tracing's (its
  // camera subpaths alone trace those; it traced 1.4 to 3 times as many on the shipped scenes).
  bool bdpt_could_win(uint32_t done) const;
  // Whether one more pilot iteration, costing about what the last ones did, would take the
  // pilot's own rays past kPilotBudget of path tracing's predicted render, or its own time past
  // kPilotBudget of the render's time limit: a render that the limit ends is as long as the limit
  // (and not reproducible by its seed anyway), and rays undercount bidirectional path tracing's
  // work on long paths (its MIS weights grow with the path: on villa, 32 pilot iterations on a
  // 25th of the pixels took 1.06 s of a render of 76 iterations in 10 s, bench_reference).
  bool over_budget(uint32_t bdpt_done) const;
  void run_bidirectional(uint32_t index);
  // Path tracing's whole render, in rays: to the error target, or the samples asked for, whichever
  // is fewer; a render stopped by its time limit alone has no prediction (the pilot runs in full).
  double predicted_pt_render() const;

  const ReferenceOptions& options_;
  BdptPass& bdpt_;
  tbb::task_arena& arena_;
  tbb::combinable<uint64_t>& ray_count_;
  int stride_;
  Pilot pilot_;
  size_t frame_size_;
  std::vector<glm::vec3> frame_, splat_frame_;  // allocated at the first bidirectional iteration
  uint32_t seed_;
  double pt_rays_ = 0, photon_rays_ = 0, bdpt_rays_ = 0;  // full-image rays, summed
  double spent_ = 0;      // the pilot's own rays, bidirectional ones weighted by kBdptRayCost
  uint32_t watched_ = 0;  // render iterations seen
  PilotReport report_;
};

}  // namespace pb::trace::detail
