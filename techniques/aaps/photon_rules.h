// AAPS's photons as the thesis traces them (seed 004 §1.4-1.5, §3.3.1), as the photon tracer's two
// policies: the task buffer's emission (GridEmission, an EmissionSampler) and the caustic rule at
// each surface interaction (CausticSplitRule, a VertexPolicy). The tracer keeps the physics (the
// Fresnel shares of a split, the differentials' transfer); these say where photons start, when
// they split, where they are stored and when they end. Header-only so that the tests check the
// very code the plugin runs.
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>
#include <limits>
#include <optional>
#include <vector>

#include "photonbench/error.h"
#include "photonbench/photons.h"
#include "photonbench/trace_math.h"

namespace aaps {

// PhotonRecord::flags of the refracted part of a split photon (§3.3.1); clear for the reflected.
constexpr uint32_t kRefractedHalf = 1u;

// Interleaves the bits of x (even bits) and y (odd bits): the order in which a sum quadtree with
// children (0,0), (1,0), (0,1), (1,1) lists its leaves.
inline uint32_t morton_xy(uint32_t x, uint32_t y) {
  uint32_t code = 0;
  for (uint32_t b = 0; b < 16; ++b)
    code |= ((x >> b) & 1u) << (2 * b) | ((y >> b) & 1u) << (2 * b + 1);
  return code;
}

// The emission order of one light's task buffer (§1.4): the texels of its density in the order a
// sum-quadtree walk visits them (Morton order, x bit first), each texel's n = floor(sqrt(D))^2
// tasks row by row over its m x m grid.
class TaskGrid {
 public:
  explicit TaskGrid(const pb::trace::EmissionDensity& counts) {
    const int side = counts.width;
    if (side <= 0 || counts.height != side || (side & (side - 1)) != 0 || side > 65536 ||
        counts.texels.size() != size_t(side) * side)
      throw pb::InputError(fmt::format(
          "aaps: the task buffer needs a square density of power-of-two side, not {}x{}",
          counts.width, counts.height));
    side_ = uint32_t(side);
    const size_t n = size_t(side) * side;
    texel_.resize(n), first_.resize(n), m_.resize(n);
    for (uint32_t y = 0; y < side_; ++y)
      for (uint32_t x = 0; x < side_; ++x) texel_[morton_xy(x, y)] = y * side_ + x;
    uint64_t sum = 0;
    for (size_t k = 0; k < n; ++k) {
      const float d = counts.texels[texel_[k]];
      const uint32_t m = d >= 1 ? uint32_t(std::floor(std::sqrt(double(d)))) : 0;  // n = m^2
      m_[k] = m;
      first_[k] = uint32_t(sum);
      sum += uint64_t(m) * m;
      if (sum > std::numeric_limits<uint32_t>::max())
        throw pb::InputError("aaps: the task buffer's density asks for more than 2^32 photons");
    }
    total_ = uint32_t(sum);
  }
  uint32_t tasks() const { return total_; }
  uint32_t side() const { return side_; }
  struct Task {
    uint32_t texel;  // row-major index (v * side + u)
    uint32_t cell;   // row-major index in the texel's m x m grid
    uint32_t m;
    glm::vec2 uv;  // the cell centre in the emission domain
  };
  Task locate(uint32_t task) const {  // task < tasks()
    // The last texel whose first task is at most `task`: texels of no photons share their
    // successor's first task, so this is the one that holds it.
    const size_t k =
        size_t(std::upper_bound(first_.begin(), first_.end(), task) - first_.begin()) - 1;
    Task t;
    t.texel = texel_[k];
    t.m = m_[k];
    t.cell = task - first_[k];
    const float x = float(t.texel % side_), y = float(t.texel / side_);
    t.uv = glm::vec2((x + (float(t.cell % t.m) + 0.5f) / float(t.m)) / float(side_),
                     (y + (float(t.cell / t.m) + 0.5f) / float(t.m)) / float(side_));
    return t;
  }
  // A fixed pseudo-random point of the task's cell (a hash of texel, cell and m) in place of its
  // centre: still one photon per cell, so evenly spaced, but no longer a lattice, whose tiny splats
  // at a focus cover a pixel centre all together or not at all as the lattice slides over the
  // pixel grid. A seed axis' scramble is hashed in too, so that its photons lie at other points of
  // the same cells: the emission has no other randomness.
  glm::vec2 jittered(const Task& t, std::optional<uint32_t> seed_scramble = std::nullopt) const {
    uint32_t h = pb::trace::hash_combine(t.texel, t.cell, t.m);
    if (seed_scramble) h = pb::trace::hash_combine(h, *seed_scramble);
    const glm::vec2 u(float(h & 0xffffu) / 65536.f, float(h >> 16) / 65536.f);
    const float x = float(t.texel % side_), y = float(t.texel / side_);
    return glm::vec2((x + (float(t.cell % t.m) + u.x) / float(t.m)) / float(side_),
                     (y + (float(t.cell / t.m) + u.y) / float(t.m)) / float(side_));
  }
  // Photons the texel of `t` emits per unit of the emission domain: texels x n (§3.2.1: each
  // photon carries the light's power / texels / n).
  float photon_density(const Task& t) const {
    return float(side_) * float(side_) * float(t.m) * float(t.m);
  }

 private:
  uint32_t side_ = 0, total_ = 0;
  std::vector<uint32_t> texel_;  // Morton position -> row-major texel
  std::vector<uint32_t> first_;  // Morton position -> its first task (exclusive prefix sum)
  std::vector<uint32_t> m_;      // Morton position -> m
};

// The task buffers of every light as one emission: light 0's tasks, then light 1's, ... A photon's
// PhotonRecord::path is its task within its light (what SumQuadtree::walk takes).
class GridEmission final : public pb::trace::EmissionSampler {
 public:
  // Photon counts D per texel of each light, in the tracer's light order (square, power-of-two
  // side). Kept by pointer: the caller keeps them alive and may change them between traces.
  void set_counts(std::vector<const pb::trace::EmissionDensity*> counts) {
    counts_ = std::move(counts);
  }
  void set_jitter(bool jitter) { jitter_ = jitter; }

  uint64_t prepare(const pb::trace::EmissionFrame& frame) override {
    grids_.clear();
    first_task_.clear();
    seed_scramble_ = frame.seed_scramble;
    uint64_t total = 0;
    for (uint32_t e = 0; e < frame.emitters.size(); ++e) {
      const pb::trace::EmitterKind kind = frame.emitters[e].kind;
      if (kind != pb::trace::EmitterKind::point && kind != pb::trace::EmitterKind::spot &&
          kind != pb::trace::EmitterKind::directional)
        throw pb::InputError(fmt::format(
            "aaps: emits from point, spot and directional lights only, light {} is an area light "
            "(seed 004 §4.5.3: its task buffer would need four dimensions)",
            e));
      if (e >= counts_.size() || counts_[e] == nullptr || counts_[e]->texels.empty())
        throw pb::InputError(fmt::format("aaps: no task buffer for light {}", e));
      grids_.emplace_back(*counts_[e]);
      first_task_.push_back(uint32_t(total));
      const glm::vec3 power = frame.emitters[e].power;
      total += (power.x + power.y + power.z) / 3.f > 0 ? grids_.back().tasks() : 0;
      if (total > std::numeric_limits<uint32_t>::max())
        throw pb::InputError("aaps: the task buffers ask for more than 2^32 photons");
    }
    first_task_.push_back(uint32_t(total));
    return total;
  }

  pb::trace::EmissionPoint emission(uint64_t i) const override {
    const uint32_t g = uint32_t(i);
    const uint32_t e = uint32_t(std::upper_bound(first_task_.begin(), first_task_.end(), g) -
                                first_task_.begin()) -
                       1;
    const TaskGrid& grid = grids_[e];
    const TaskGrid::Task task = grid.locate(g - first_task_[e]);
    pb::trace::EmissionPoint point;
    point.light = e;
    point.uv = jitter_ ? grid.jittered(task, seed_scramble_) : task.uv;
    point.direction = {0.5f, 0.5f};
    point.photon_density = grid.photon_density(task);
    point.id = g - first_task_[e];
    return point;
  }

  // Per light, per texel (row-major): the power its photons left the light with (mean over RGB,
  // W), summed from a trace's PhotonBatch::emitted_power in task order (a texel's tasks are
  // consecutive, so the sums do not depend on the thread count): the denominator of a photon's
  // energy fraction in its texel (§3.1.5).
  std::vector<std::vector<float>> power_per_texel(const std::vector<float>& emitted_power) const {
    std::vector<std::vector<float>> power(grids_.size());
    for (uint32_t e = 0; e < grids_.size(); ++e) {
      power[e].assign(size_t(grids_[e].side()) * grids_[e].side(), 0.f);
      for (uint32_t g = first_task_[e]; g < first_task_[e + 1]; ++g)
        power[e][grids_[e].locate(g - first_task_[e]).texel] += emitted_power[g];
    }
    return power;
  }

 private:
  std::vector<const pb::trace::EmissionDensity*> counts_;
  bool jitter_ = false;
  std::vector<TaskGrid> grids_;
  std::vector<uint32_t> first_task_;  // per light, then the total
  std::optional<uint32_t> seed_scramble_;
};

// The thesis's rule at each surface interaction (§1.5, §3.3.1): the first hit must be a
// dielectric, else the photon is discarded; the first dielectric hit splits it into its reflected
// and refracted parts (Fresnel shares), and every later specular hit repeats the part's last
// interaction (refraction under total internal reflection reflects); a part is stored at its first
// diffuse hit only (L S+ D), or lost at max_bounces, the recursion cap. Glossy (rough) surfaces end
// the photon. No Russian roulette: every decision is deterministic.
class CausticSplitRule final : public pb::trace::VertexPolicy {
 public:
  pb::trace::VertexDecision decide(const pb::trace::Interaction& at) const override {
    using pb::trace::Scatter;
    using pb::trace::SurfaceKind;
    pb::trace::VertexDecision d;
    d.scatter = Scatter::end;
    d.state = at.state;
    // The vertex after the split knows which part it is: its arriving segment was refracted.
    if (d.state & kJustSplit)
      d.state = kSplit | (at.arrived_by == Scatter::refract ? kRefractedPart : 0u);
    if (at.surface == SurfaceKind::diffuse) {
      d.store = at.index > 0;  // L D is not a caustic photon
      d.photon_flags = (d.state & kRefractedPart) ? kRefractedHalf : 0u;
      return d;
    }
    const bool dielectric = at.surface == SurfaceKind::dielectric;
    const bool mirror = at.surface == SurfaceKind::mirror;
    if (at.index == 0 && !dielectric) return d;  // §1.5: the first hit must be a dielectric
    if (!dielectric && !mirror) return d;        // glossy surfaces end the photon
    if (dielectric && !(d.state & kSplit)) {
      d.scatter = Scatter::split;  // §3.3.1: split once, both parts marked as split
      d.state = kSplit | kJustSplit;
    } else {
      d.scatter = mirror || at.arrived_by != Scatter::refract ? Scatter::reflect : Scatter::refract;
    }
    return d;
  }

 private:
  static constexpr uint32_t kSplit = 1u, kJustSplit = 2u, kRefractedPart = 4u;
};

}  // namespace aaps
