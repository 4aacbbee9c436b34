#include "reference/estimator_pilot.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "io/clock.h"
#include "trace/sampling.h"

namespace pb::trace::detail {

Pilot::Pilot(int width, int height, int stride, const std::vector<int>& classes)
    : classes_(classes), stride_(stride) {
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      if (in_grid(x, y, stride)) pixels_.push_back(size_t(y) * width + x);
  for (auto& m : moments_) m.resize(pixels_.size() * classes_.size());
}

void Pilot::add(Part part, const std::vector<glm::vec3>& frame) {
  const size_t k = classes_.size();
  if (part == path_tracing) last_path_tracing_.assign(pixels_.size() * k, 0.0);
  for (size_t p = 0; p < pixels_.size(); ++p) {
    const glm::vec3* v = &frame[pixels_[p] * kClasses];
    for (size_t j = 0; j < k; ++j) {
      double l = 0;
      if (classes_[j] == int(PathClass::combined))
        for (int c = 0; c < kClasses; ++c) l += luminance(v[c]);
      else
        l = luminance(v[classes_[j]]);
      size_t slot = p * k + j;
      if (part == path_tracing) last_path_tracing_[slot] = l;
      if (part == photons && !last_path_tracing_.empty()) l -= last_path_tracing_[slot];
      moments_[part][slot].add(l);
    }
  }
  ++iterations_[part];
}

double Pilot::error2(bool bdpt) const {
  std::vector<double> class_mean(classes_.size(), 0.0);
  for (size_t p = 0; p < pixels_.size(); ++p)
    for (size_t j = 0; j < classes_.size(); ++j) class_mean[j] += mean(p, j) / pixels_.size();
  double acc = 0;
  size_t counted = 0;
  for (size_t p = 0; p < pixels_.size(); ++p)
    for (size_t j = 0; j < classes_.size(); ++j) {
      if (!(class_mean[j] > 0)) continue;
      size_t slot = p * classes_.size() + j;
      double var = variance(photons, slot);
      var += bdpt ? variance(bidirectional, slot) +
                        variance(splats, slot) / (double(stride_) * stride_)
                  : variance(path_tracing, slot);
      double m = mean(p, j);
      acc += var / (m * m + std::pow(0.01 * class_mean[j], 2.0));
      ++counted;
    }
  return counted ? acc / double(counted) : 0.0;
}

double Pilot::variance(Part part, size_t slot) const {
  return moments_[part][slot].variance(iterations_[part]);
}

double Pilot::mean(size_t p, size_t j) const {
  size_t slot = p * classes_.size() + j;
  return 0.5 * (mean(path_tracing, slot) + mean(bidirectional, slot) + mean(splats, slot)) +
         mean(photons, slot);
}

int pilot_stride(size_t pixels) { return std::max(1, int(std::sqrt(double(pixels) / 2000.0))); }

EstimatorPilot::EstimatorPilot(const Rig& rig, const ReferenceOptions& options,
                               const std::vector<int>& classes, BdptPass& bdpt,
                               tbb::task_arena& arena, tbb::combinable<uint64_t>& ray_count)
    : options_(options),
      bdpt_(bdpt),
      arena_(arena),
      ray_count_(ray_count),
      stride_(pilot_stride(size_t(rig.width) * rig.height)),
      pilot_(rig.width, rig.height, stride_, classes),
      frame_size_(size_t(rig.width) * rig.height * kClasses),
      seed_(hash_combine(options.seed, 0x9170u)) {}

void EstimatorPilot::observe(Pilot::Part part, const std::vector<glm::vec3>& frame, uint64_t rays) {
  pilot_.add(part, frame);
  (part == Pilot::photons ? photon_rays_ : pt_rays_) += double(rays);
}

std::optional<Estimator> EstimatorPilot::step(uint32_t done) {
  watched_ = done;
  if (done < 2) return std::nullopt;  // path tracing's variance needs two iterations
  predict(done);
  uint32_t bdpt_done = pilot_.iterations(Pilot::bidirectional);
  if (bdpt_done < kPilotBdptIterations && bdpt_could_win(done)) {
    if (bdpt_done > 0 && over_budget(bdpt_done)) {
      report_.why = "path tracing: one more pilot iteration would pass its budget";
      return Estimator::pt;
    }
    run_bidirectional(bdpt_done);
    predict(done);
    ++bdpt_done;
  }
  if (bdpt_done >= kPilotMinIterations &&
      report_.bdpt_cost * kPilotMargin < pt_left(done, report_.pt_cost)) {
    report_.why = "bidirectional: predicted cheaper than what path tracing has left";
    return Estimator::bdpt;
  }
  if (done >= kPilotIterations) {
    report_.why = "path tracing: not beaten in the iterations the pilot watches";
    return Estimator::pt;
  }
  return std::nullopt;
}

PilotReport EstimatorPilot::report() const {
  PilotReport r = report_;
  r.ran = true;
  r.iterations = watched_;
  r.bdpt_iterations = pilot_.iterations(Pilot::bidirectional);
  r.pilot_rays = spent_;
  return r;
}

void EstimatorPilot::predict(uint32_t done) {
  uint32_t n_photon = std::max(1u, pilot_.iterations(Pilot::photons));
  uint32_t n_bdpt = std::max(1u, pilot_.iterations(Pilot::bidirectional));
  report_.pt_rays = pt_rays_ / done, report_.bdpt_rays = bdpt_rays_ / n_bdpt;
  report_.photon_rays = photon_rays_ / n_photon;
  report_.pt_error2 = pilot_.error2(false);
  report_.bdpt_error2 = pilot_.error2(true);
  double pt_iteration = report_.pt_rays_per_iteration();
  double bdpt_iteration = kBdptRayCost * report_.bdpt_rays + report_.photon_rays;
  if (options_.rel_error > 0) {
    double target2 = double(options_.rel_error) * options_.rel_error;
    double least = std::max(2u, options_.min_samples);
    report_.pt_cost = std::max(least, report_.pt_error2 / target2) * pt_iteration;
    report_.bdpt_cost = std::max(least, report_.bdpt_error2 / target2) * bdpt_iteration;
  } else {  // error^2 x cost per iteration: the cost of any given error
    report_.pt_cost = report_.pt_error2 * pt_iteration;
    report_.bdpt_cost = report_.bdpt_error2 * bdpt_iteration;
  }
  report_.budget = kPilotBudget * predicted_pt_render();
}

double EstimatorPilot::pt_left(uint32_t done, double pt_cost) const {
  if (!(options_.rel_error > 0)) return pt_cost;
  return pt_cost - double(done) * report_.pt_rays_per_iteration();
}

bool EstimatorPilot::bdpt_could_win(uint32_t done) const {
  if (!(options_.rel_error > 0)) return true;
  double least = std::max(2u, options_.min_samples);
  double bdpt_rays = pilot_.iterations(Pilot::bidirectional) ? report_.bdpt_rays : report_.pt_rays;
  double floor = least * (kBdptRayCost * bdpt_rays + report_.photon_rays);
  return floor * kPilotMargin < pt_left(done, report_.pt_cost);
}

bool EstimatorPilot::over_budget(uint32_t bdpt_done) const {
  double rays = spent_ * (bdpt_done + 1.0) / bdpt_done;
  double seconds = report_.seconds * (bdpt_done + 1.0) / bdpt_done;
  return rays > report_.budget ||
         (options_.max_seconds > 0 && seconds > kPilotBudget * options_.max_seconds);
}

void EstimatorPilot::run_bidirectional(uint32_t index) {
  auto t0 = std::chrono::steady_clock::now();
  if (frame_.empty()) frame_.resize(frame_size_), splat_frame_.resize(frame_size_);
  const double scale = double(stride_) * stride_;  // full-image rays per grid ray
  uint64_t rays =
      bdpt_.run(hash_combine(seed_, index, 1u), arena_, ray_count_, frame_, stride_, &splat_frame_);
  bdpt_rays_ += scale * double(rays);
  spent_ += kBdptRayCost * double(rays);
  pilot_.add(Pilot::bidirectional, frame_);
  pilot_.add(Pilot::splats, splat_frame_);
  report_.seconds += io::seconds_since(t0);
}

double EstimatorPilot::predicted_pt_render() const {
  double render = std::numeric_limits<double>::infinity();
  if (options_.rel_error > 0) render = report_.pt_cost;
  if (options_.samples > 0)
    render = std::min(render, double(options_.samples) * report_.pt_rays_per_iteration());
  return render;
}

}  // namespace pb::trace::detail
