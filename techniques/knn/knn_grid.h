// The knn technique's photon map and query, apart from the plugin so that the tests drive the very
// code it runs (tests/knn_test.cpp, through tests/support/gpu_context.h): a uniform grid over the
// photons built on the GPU with the toolkit's CountingSort (photons binned by cell, each cell's
// range found, the photons copied in cell order), and the k-nearest-neighbour density estimate per
// G-buffer sample over it (shaders/knn_gather.comp). README.md gives the choices and their reasons.
//
//   KnnGrid grid;  grid.setup(gpu, settings);
//   grid.build(cmd, gpu, photon_buffer, records);          // plans the grid on the CPU, records
//   grid.gather(cmd, gbuffer, width, height, indirect);    // records the queries
//   ... submit, wait ...   grid.read_stats()
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "knn_layout.h"
#include "photonbench/context.h"
#include "photonbench/gpu.h"
#include "photonbench/photons.h"
#include "photonbench/toolkit/gpu_scan.h"

namespace knn {

// The query's settings (the parameters of README.md's table).
struct Settings {
  uint32_t k = 100;
  float r_max = 0.25f;     // m
  float cell_size = 0.0f;  // m; 0: automatic (plan_grid)
  uint32_t kernel = KNN_KERNEL_UNIFORM;
  uint32_t sparse = KNN_SPARSE_RMAX;
  float bin_width = 0.05f;  // m, the radius histogram's
  uint32_t budget = 60000;  // loop steps per query invocation
  uint32_t search = KNN_SEARCH_GRID;
  uint32_t heap = KNN_HEAP_PRIVATE;
};

// The grid's cells most: 2^21 (20 bytes a cell with the sort's counters: 40 MiB). A finer cell
// size is coarsened to fit.
inline constexpr uint32_t kMaxGridCells = 1u << 21;

// The uniform grid over a set of photons, planned on the CPU from their bounds.
struct GridLayout {
  glm::vec3 origin{0.0f}, grid_max{0.0f};
  float cell = 1.0f;
  std::array<uint32_t, 3> dims{1, 1, 1};
  uint32_t cells() const { return dims[0] * dims[1] * dims[2]; }
};

// The cell size `cell_size: 0` chooses: the k-th-neighbour distance the photons would have if they
// were spread evenly over the surface of their bounding box, sqrt(k A / (pi n)), so that a query's
// k photons lie in about the 3x3 cells around it on a surface (README.md, "The grid"); at most
// r_max.
float automatic_cell_size(glm::vec3 extent, uint32_t photons, uint32_t k, float r_max);

// The grid over `records` for `settings`: their bounds grown by half a cell on each side, cells of
// settings.cell_size (or automatic_cell_size), coarsened until there are at most kMaxGridCells.
GridLayout plan_grid(std::span<const pb::trace::PhotonRecord> records, const Settings& settings);

// The balanced kd-tree of seed 003's baseline (Jensen 1996, "balanced"): the toolkit's KdTree
// (photonbench/toolkit/kd_tree.h: each node a photon, the median along its subtree's widest axis,
// in the implicit order of a complete binary tree, node i's children 2i + 1 and 2i + 2) with each
// node's photon record laid out for the GPU walk, `axis` set. `index` is the photon's record index,
// as the grid's.
std::vector<KnnPhoton> build_kdtree(std::span<const pb::trace::PhotonRecord> records);

// One frame's query statistics (KNN_STAT_* words) and the build's occupied cells.
struct Stats {
  uint64_t visited = 0, cells_opened = 0, found = 0, heap_entries = 0;
  uint32_t queries = 0, short_queries = 0, truncated = 0, occupied = 0;
  std::array<uint32_t, KNN_RADIUS_BINS> histogram{};
};

class KnnGrid {
 public:
  void setup(pb::gpu::Device& gpu, const Settings& settings);
  // Plans the grid over `records` (uploaded in `photons`, PhotonRecord[]) and records its build:
  // cell keys, the counting sort by cell, cell ranges and the photons in cell order. Buffers grow
  // here, before anything is recorded that uses them.
  void build(vk::CommandBuffer cmd, pb::gpu::Device& gpu, const pb::gpu::Buffer& photons,
             std::span<const pb::trace::PhotonRecord> records);
  // Records one query per pixel of `gbuffer` (width x height) into `indirect` (RGBA32F radiance).
  // debug: also write each query's found photons (their record indices) and radius, read by
  // debug_queries after the submission.
  void gather(vk::CommandBuffer cmd, pb::gpu::Device& gpu, const pb::GBuffer& gbuffer,
              uint32_t width, uint32_t height, const pb::gpu::Image& indirect, bool debug = false);
  // After the submission of the gather (and of the build for `occupied`).
  Stats read_stats() const;

  struct Query {
    uint32_t found = 0;
    float radius = 0;
    std::vector<uint32_t> photons;  // record indices, in no order
  };
  // The debug output of the last gather with debug = true, pixel by pixel (row-major).
  std::vector<Query> debug_queries(pb::gpu::Device& gpu) const;

  const GridLayout& layout() const { return layout_; }
  uint32_t photon_count() const { return photon_count_; }
  // The bytes of the photon map: cell ranges, the sort's items and counters, the scan's scratch,
  // the photons in cell order (the uploaded records are counted apart, bytes_photons).
  uint64_t bytes() const;

 private:
  KnnPush push() const;

  Settings settings_;
  GridLayout layout_;
  uint32_t photon_count_ = 0, width_ = 0, height_ = 0;
  pb::toolkit::PrefixSum scan_;
  pb::toolkit::CountingSort sort_;
  pb::gpu::Buffer items_, sorted_, cells_, compact_, stats_, debug_, args_;
  pb::gpu::Buffer tree_;  // search kdtree: the nodes (host-visible), bound where compact_ is
  pb::gpu::Buffer heap_;  // heap global: k entries per pixel (a stand-in of 8 bytes otherwise)
  const pb::gpu::Buffer* photons_ = nullptr;  // the buffer the last build read
  pb::gpu::Pipeline keys_pipeline_, ranges_pipeline_, gather_pipeline_;
};

}  // namespace knn
