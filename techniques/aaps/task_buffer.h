// AAPS's task buffer (seed 004 §1.4, §1.10) on the CPU: the ray-density texture D of one light, the
// sum quadtree over its photon counts and the per-frame feedback D' = D A / A_t + v g with the
// spatio-temporal blend. Header-only so that the tests check the very code the plugin runs.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace aaps {

// Photons a texel of density D emits: the nearest square at most D (§1.4.1).
inline uint32_t grid_side(float density) {
  return density >= 1 ? uint32_t(std::floor(std::sqrt(double(density)))) : 0;
}

// The sum quadtree (§3.1.5): level 0 holds each texel's photon count floor(sqrt(D))^2, row-major;
// every node of level l + 1 the sum of its four children; the last level is the root, the number
// of photons emitted.
class SumQuadtree {
 public:
  void build(const std::vector<float>& density, uint32_t side) {
    levels_.assign(1, std::vector<uint32_t>(size_t(side) * side));
    for (size_t t = 0; t < levels_[0].size(); ++t) {
      uint32_t m = grid_side(density[t]);
      levels_[0][t] = m * m;
    }
    for (uint32_t s = side; s > 1; s /= 2) {
      const std::vector<uint32_t>& below = levels_.back();
      std::vector<uint32_t> level(size_t(s / 2) * (s / 2));
      for (uint32_t y = 0; y < s / 2; ++y)
        for (uint32_t x = 0; x < s / 2; ++x)
          level[y * (s / 2) + x] = below[2 * y * s + 2 * x] + below[2 * y * s + 2 * x + 1] +
                                   below[(2 * y + 1) * s + 2 * x] +
                                   below[(2 * y + 1) * s + 2 * x + 1];
      levels_.push_back(std::move(level));
    }
  }
  uint32_t root() const { return levels_.empty() ? 0 : levels_.back()[0]; }

  struct Leaf {
    uint32_t texel;  // row-major
    uint32_t cell;   // row-major within the texel's m x m grid
    uint32_t m;
  };
  // Task `task` < root(): from the root down, the child whose cumulative range holds the task
  // (children (0,0), (1,0), (0,1), (1,1); ranges 0-based and half-open, Fig. 15), less the sums of
  // the children before it; at the leaf the rest picks the grid cell.
  Leaf walk(uint32_t task) const {
    uint32_t x = 0, y = 0;
    for (size_t l = levels_.size() - 1; l > 0; --l) {
      const std::vector<uint32_t>& children = levels_[l - 1];
      uint32_t s = uint32_t(std::lround(std::sqrt(double(children.size()))));
      uint32_t cx = 2 * x, cy = 2 * y;
      for (uint32_t c = 0; c < 4; ++c) {
        uint32_t nx = cx + (c & 1u), ny = cy + (c >> 1);
        uint32_t sum = children[ny * s + nx];
        if (task < sum || c == 3) {
          x = nx, y = ny;
          break;
        }
        task -= sum;
      }
    }
    uint32_t side = uint32_t(std::lround(std::sqrt(double(levels_[0].size()))));
    uint32_t texel = y * side + x;
    return {texel, task, grid_side(float(levels_[0][texel]))};
  }

 private:
  std::vector<std::vector<uint32_t>> levels_;
};

struct FeedbackParams {
  float target_area = 19;       // A_t, px^2
  float variance_gain = 2;      // g, photons per unit of relative temporal difference
  float temporal_weight = 0.5;  // w_t: share of the new suggestion D'
  float neighbour_weight =
      0.5;  // w_i of each 4-neighbour's previous value, against 1 for the texel
  float density_min = 4;
  float density_max = 0;  // 0: none

  constexpr bool operator==(const FeedbackParams&) const = default;
};

// §1.10 b-c: D' = D A / A_t + v g per texel, then D = w_t D' + (1 - w_t) (sum w_i D_i) / sum w_i
// over the texel's and its four neighbours' previous values, clamped to [min, max].
inline void update_density(std::vector<float>& density, const std::vector<float>& area,
                           const std::vector<float>& variance, uint32_t side,
                           const FeedbackParams& p) {
  std::vector<float> next(density.size());
  for (uint32_t y = 0; y < side; ++y)
    for (uint32_t x = 0; x < side; ++x) {
      size_t t = size_t(y) * side + x;
      float suggested = density[t] * area[t] / p.target_area + variance[t] * p.variance_gain;
      float sum = density[t], weights = 1;
      const int dx[4] = {-1, 1, 0, 0}, dy[4] = {0, 0, -1, 1};
      for (int k = 0; k < 4; ++k) {
        int nx = int(x) + dx[k], ny = int(y) + dy[k];
        if (nx < 0 || ny < 0 || nx >= int(side) || ny >= int(side)) continue;
        sum += p.neighbour_weight * density[size_t(ny) * side + nx];
        weights += p.neighbour_weight;
      }
      float d = p.temporal_weight * suggested + (1 - p.temporal_weight) * sum / weights;
      d = std::max(d, p.density_min);
      if (p.density_max > 0) d = std::min(d, p.density_max);
      next[t] = d;
    }
  density.swap(next);
}

}  // namespace aaps
