// Paper II's distribution maps (§3.1, §4): per light a target map DM_T and a current map DM_C over
// the light's emission domain, counting the paths that leave each cell; over-full cells are pruned
// with probability (DM_C - DM_T) / DM_C (Eq. 1) and the freed paths refill under-full cells by
// sampling the light inside them, so that after a light moves the photon distribution converges
// back to the target.
//
// The maps live in the tracer's emission-sample space (photonbench/photons.h, EmissionDensity),
// where equal volumes carry equal power: point and spot lights, 2-D over direction (the
// equal-area sphere or cone coordinates of LightPath::emission_uv); area lights (those whose
// emission vertex has a normal), 4-D over position (emission_uv) and direction (emission_dir, the
// cosine map's square). So DM_T of a light of uniform emission is uniform: paths / cells per cell
// (a textured light would give a non-uniform DM_T; none is used here). Header-only, so that the
// tests drive these very functions with a tracer.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "photonbench/photons.h"

namespace pb::pathverification {

// A deterministic random number in [0, 1) per (frame, path, stream) (SplitMix64 finaliser).
inline double hash_unit(uint64_t frame, uint64_t path, uint64_t stream) {
  uint64_t z = frame * 0x9E3779B97F4A7C15ull ^ (path + 1) * 0xBF58476D1CE4E5B9ull ^
               (stream + 1) * 0x94D049BB133111EBull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return double(z >> 11) * 0x1.0p-53;
}

struct DistributionMap {
  bool area = false;  // 4-D (position x direction) rather than 2-D (direction)
  uint32_t position_cells = 8, direction_cells = 64;  // per dimension
  std::vector<float> target;                          // DM_T: expected paths per cell
  std::vector<uint32_t> current;                      // DM_C
  // distance() of the light's first trace: how close a fresh trace comes to DM_T.
  double fresh_distance = 0;

  uint32_t cells() const {
    uint32_t d = direction_cells * direction_cells;
    return area ? d * position_cells * position_cells : d;
  }
  static uint32_t bin(float x, uint32_t n) {
    return std::min(n - 1, uint32_t(std::max(0.f, x) * float(n)));
  }
  // The cell a path leaves from.
  uint32_t cell_of(const trace::LightPath& path) const {
    uint32_t d = direction_cells;
    glm::vec2 dir = area ? path.emission_dir : path.emission_uv;
    uint32_t cell = bin(dir.x, d) * d + bin(dir.y, d);
    if (!area) return cell;
    uint32_t p = position_cells;
    uint32_t position = bin(path.emission_uv.x, p) * p + bin(path.emission_uv.y, p);
    return position * d * d + cell;
  }
  // An emission sample uniform inside `cell` (u: two or four numbers in [0, 1)): sets the path's
  // emission_uv and emission_dir.
  void sample_in_cell(uint32_t cell, const glm::vec4& u, trace::LightPath& path) const {
    uint32_t d = direction_cells, p = position_cells;
    uint32_t dir_cell = cell % (d * d);
    glm::vec2 dir{(float(dir_cell / d) + u.x) / float(d), (float(dir_cell % d) + u.y) / float(d)};
    if (!area) {
      path.emission_uv = dir;
      return;
    }
    uint32_t pos_cell = cell / (d * d);
    path.emission_dir = dir;
    path.emission_uv = {(float(pos_cell / p) + u.z) / float(p),
                        (float(pos_cell % p) + u.w) / float(p)};
  }
  // The total-variation distance between DM_C and DM_T, as a fraction of the paths (0: equal).
  double distance() const {
    double sum = 0, total = 0;
    for (size_t c = 0; c < target.size(); ++c)
      sum += std::abs(double(current[c]) - target[c]), total += target[c];
    return total > 0 ? sum / (2 * total) : 0;
  }
};

// The maps of every light of a batch, and the steps of §3.1 on them.
class DistributionMaps {
 public:
  // Sizes a map per light from the batch's first trace (area lights: emission vertices with a
  // normal) with DM_T uniform over the light's paths.
  void setup(const trace::PhotonBatch& batch, uint32_t position_cells, uint32_t direction_cells) {
    const auto& paths = batch.paths.paths;
    split_ = batch.paths.paths_per_light;
    position_cells_ = position_cells;
    direction_cells_ = direction_cells;
    maps_.assign(batch.paths.paths_per_light.size(), DistributionMap{});
    for (size_t l = 0; l < maps_.size(); ++l) {
      maps_[l].position_cells = position_cells;
      maps_[l].direction_cells = direction_cells;
    }
    for (const auto& path : paths)
      maps_[path.light].area = batch.paths.vertices[path.first_vertex].normal != glm::vec3(0.f);
    for (size_t l = 0; l < maps_.size(); ++l) {
      DistributionMap& m = maps_[l];
      m.target.assign(m.cells(), float(batch.paths.paths_per_light[l]) / float(m.cells()));
      m.current.assign(m.cells(), 0);
    }
    compute(batch);
    for (DistributionMap& m : maps_) m.fresh_distance = m.distance();
  }
  bool empty() const { return maps_.empty(); }
  const std::vector<DistributionMap>& maps() const { return maps_; }

  // compute-dm: DM_C from the paths whose origin is kept (restart != kReemit). A power change
  // re-splits the paths among the lights in a fresh trace (§3.1's DM_T is uniform over a light's
  // paths): the maps are then made anew from that trace, as at the first frame; against the old
  // split's DM_T a light that gained paths would be over-full in every cell, and prune and fill
  // would re-trace a share of its paths every frame of a static scene.
  void compute(const trace::PhotonBatch& batch) {
    if (batch.paths.paths_per_light != split_)
      return setup(batch, position_cells_, direction_cells_);
    for (auto& m : maps_) std::fill(m.current.begin(), m.current.end(), 0u);
    for (const auto& path : batch.paths.paths)
      if (path.restart != trace::LightPath::kReemit) ++maps_[path.light].current[cell_of(path)];
  }

  // prune (Eq. 1): lists in `pruned` (the pruned-paths array) the paths of over-full cells drawn
  // with probability (DM_C - DM_T) / DM_C, against the DM_C of compute() (the paper's two passes:
  // mark, then update the map). Only a light whose DM_C is further from DM_T than its first
  // trace's is pruned (a light that never moved is never pruned: measured, a static disc light's
  // 4-D map of about 9 paths a cell lost 7-18% of its paths to prune and fill in the first frame
  // without this), and then a cell is left alone until it holds more than ceil(DM_T) paths, so the
  // maps settle rather than churn (the paper prunes at any excess; README: deviations). Returns the
  // count.
  uint64_t prune(const trace::PhotonBatch& batch, uint64_t frame, std::vector<uint32_t>& pruned) {
    const auto& paths = batch.paths.paths;
    pruned.clear();
    std::vector<bool> settled(maps_.size());
    for (size_t l = 0; l < maps_.size(); ++l)
      settled[l] = maps_[l].distance() <= maps_[l].fresh_distance;
    for (uint32_t i = 0; i < paths.size(); ++i) {
      const trace::LightPath& path = paths[i];
      if (path.restart == trace::LightPath::kReemit || settled[path.light]) continue;
      const DistributionMap& m = maps_[path.light];
      uint32_t cell = cell_of(path);
      float t = m.target[cell], c = float(m.current[cell]);
      if (c > std::ceil(t) && hash_unit(frame, i, 0) < (c - t) / c) pruned.push_back(i);
    }
    for (uint32_t i : pruned) --maps_[paths[i].light].current[cell_of(paths[i])];
    return pruned.size();
  }

  // fill: every freed path (pruned, or kReemit: verification lost its origin) gets an emission
  // sample inside an under-full cell of its light, the cells chosen in proportion to their
  // deficits, and is marked kRefill. Returns the count.
  uint64_t fill(trace::PhotonBatch& batch, uint64_t frame, const std::vector<uint32_t>& pruned) {
    auto& paths = batch.paths.paths;
    std::vector<std::vector<uint32_t>> freed(maps_.size());
    for (uint32_t i = 0; i < paths.size(); ++i)
      if (paths[i].restart == trace::LightPath::kReemit) freed[paths[i].light].push_back(i);
    for (uint32_t i : pruned) freed[paths[i].light].push_back(i);
    uint64_t refilled = 0;
    for (size_t l = 0; l < maps_.size(); ++l) refilled += fill_light(l, freed[l], batch, frame);
    return refilled;
  }

 private:
  uint32_t cell_of(const trace::LightPath& path) const { return maps_[path.light].cell_of(path); }
  // Shares `slots` among the under-full cells of light l by their deficits (largest remainder).
  uint64_t fill_light(size_t l, const std::vector<uint32_t>& slots, trace::PhotonBatch& batch,
                      uint64_t frame) {
    if (slots.empty()) return 0;
    DistributionMap& m = maps_[l];
    std::vector<std::pair<uint32_t, double>> deficit;
    double total = 0;
    for (uint32_t c = 0; c < m.cells(); ++c) {
      double d = double(m.target[c]) - double(m.current[c]);
      if (d > 0) deficit.push_back({c, d}), total += d;
    }
    if (deficit.empty())  // nothing under-full: sample the target itself
      for (uint32_t c = 0; c < m.cells(); ++c)
        deficit.push_back({c, m.target[c]}), total += m.target[c];
    std::vector<uint32_t> cells;
    cells.reserve(slots.size());
    std::vector<std::pair<double, uint32_t>> remainders;
    for (const auto& [c, d] : deficit) {
      double exact = d / total * double(slots.size());
      uint32_t whole = uint32_t(exact);
      cells.insert(cells.end(), whole, c);
      remainders.push_back({exact - whole, c});
    }
    std::stable_sort(remainders.begin(), remainders.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    for (size_t r = 0; cells.size() < slots.size() && r < remainders.size(); ++r)
      cells.push_back(remainders[r].second);
    while (cells.size() < slots.size()) cells.push_back(remainders.front().second);
    auto& paths = batch.paths.paths;
    for (size_t k = 0; k < slots.size(); ++k) {
      trace::LightPath& path = paths[slots[k]];
      glm::vec4 u{hash_unit(frame, slots[k], 1), hash_unit(frame, slots[k], 2),
                  hash_unit(frame, slots[k], 3), hash_unit(frame, slots[k], 4)};
      m.sample_in_cell(cells[k], u, path);
      path.restart = trace::LightPath::kRefill;
      ++m.current[cells[k]];
    }
    return slots.size();
  }

  std::vector<DistributionMap> maps_;
  std::vector<uint32_t> split_;  // the paths of each light that DM_T was made for
  uint32_t position_cells_ = 0, direction_cells_ = 0;
};

}  // namespace pb::pathverification
