// KnnGrid (knn_grid.h).
#include "knn_grid.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>

#include "knn_shaders.h"
#include "photonbench/toolkit/kd_tree.h"
#include "photonbench/toolkit/technique.h"

namespace knn {

static_assert(sizeof(KnnPush) == 96, "KnnPush mirrors the GLSL push block (knn_layout.h)");
static_assert(sizeof(KnnPhoton) == 48, "std430 size of KnnPhoton");
static_assert(offsetof(KnnPhoton, power) == 16 && offsetof(KnnPhoton, direction) == 32);

namespace {

using pb::gpu::Binding;
using U = vk::BufferUsageFlagBits;

constexpr uint32_t kBuildBindings = 7;  // knn_common.glsl: bindings 0-6 are buffers
constexpr uint32_t kGroup = 64;         // knn_keys / knn_ranges local size
constexpr uint32_t kArgsCountWord = 4;  // args_: a VkDispatchIndirectCommand, then the count

// Grows `buffer` to hold `bytes` (with a quarter more, so that a photon count varying from frame
// to frame does not reallocate every frame).
void grow(pb::gpu::Device& gpu, pb::gpu::Buffer& buffer, const char* name, uint64_t bytes) {
  if (buffer && buffer.size() >= bytes) return;
  buffer = pb::toolkit::storage_buffer(gpu, name, bytes + bytes / 4);
}

}  // namespace

float automatic_cell_size(glm::vec3 extent, uint32_t photons, uint32_t k, float r_max) {
  if (photons == 0) return r_max;
  const double area = 2.0 * (double(extent.x) * extent.y + double(extent.y) * extent.z +
                             double(extent.x) * extent.z);
  const double density = photons / std::max(area, 1e-12);  // photons per m^2 of the box's faces
  const double radius = std::sqrt(double(k) / (3.14159265358979 * density));
  return float(std::min<double>(radius, r_max));
}

std::vector<KnnPhoton> build_kdtree(std::span<const pb::trace::PhotonRecord> records) {
  std::vector<glm::vec3> positions(records.size());
  for (size_t i = 0; i < records.size(); ++i) positions[i] = records[i].position;
  const pb::toolkit::KdTree balanced(positions);
  std::vector<KnnPhoton> tree;
  tree.reserve(balanced.size());
  for (const pb::toolkit::KdTree::Node& node : balanced.nodes()) {
    const pb::trace::PhotonRecord& p = records[node.index];
    tree.push_back(KnnPhoton{p.position, node.index, p.power, node.axis, p.direction, 0.0f});
  }
  return tree;
}

GridLayout plan_grid(std::span<const pb::trace::PhotonRecord> records, const Settings& settings) {
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(std::numeric_limits<float>::lowest());
  for (const auto& p : records) {
    lo = glm::min(lo, p.position);
    hi = glm::max(hi, p.position);
  }
  if (records.empty()) lo = hi = glm::vec3(0.0f);
  const glm::vec3 extent = hi - lo;
  float cell = settings.cell_size > 0 ? settings.cell_size
                                      : automatic_cell_size(extent, uint32_t(records.size()),
                                                            settings.k, settings.r_max);
  cell = std::max(cell, 1e-6f);
  GridLayout layout;
  for (;;) {
    uint64_t total = 1;
    for (int a = 0; a < 3; ++a) {
      // Half a cell of margin on each side: every photon lies strictly inside.
      layout.dims[a] = uint32_t(std::max(1.0, std::ceil(double(extent[a]) / cell + 1.0)));
      total *= layout.dims[a];
    }
    if (total <= kMaxGridCells) break;
    cell *= 1.25f;
  }
  layout.cell = cell;
  const glm::vec3 size = glm::vec3(layout.dims[0], layout.dims[1], layout.dims[2]) * cell;
  layout.origin = (lo + hi) * 0.5f - size * 0.5f;
  layout.grid_max = layout.origin + size;
  return layout;
}

void KnnGrid::setup(pb::gpu::Device& gpu, const Settings& settings) {
  settings_ = settings;
  scan_.setup(gpu);
  sort_.setup(gpu);
  stats_ = pb::toolkit::storage_buffer(gpu, "knn/stats", KNN_STAT_WORDS * 4,
                                       pb::gpu::Memory::host_visible);
  std::memset(stats_.mapped(), 0, KNN_STAT_WORDS * 4);
  debug_ = pb::toolkit::storage_buffer(gpu, "knn/debug", 16);
  args_ = gpu.create_buffer("knn/args", 32, U::eStorageBuffer | U::eIndirectBuffer,
                            pb::gpu::Memory::host_visible);
  std::vector<Binding> build(kBuildBindings, Binding::storage_buffer);
  std::vector<Binding> gather = build;
  gather.insert(gather.end(), 4, Binding::storage_image);
  gather.push_back(Binding::storage_buffer);  // the heap (knn_common.glsl, binding 11)
  heap_ = pb::toolkit::storage_buffer(gpu, "knn/heap", 8);
  keys_pipeline_ =
      gpu.create_compute_pipeline("build/keys", kknn_keys_comp_spv, build, sizeof(KnnPush));
  ranges_pipeline_ =
      gpu.create_compute_pipeline("build/ranges", kknn_ranges_comp_spv, build, sizeof(KnnPush));
  gather_pipeline_ =
      gpu.create_compute_pipeline("gather", kknn_gather_comp_spv, gather, sizeof(KnnPush));
}

KnnPush KnnGrid::push() const {
  KnnPush p{};
  p.origin = layout_.origin;
  p.cell = layout_.cell;
  p.grid_max = layout_.grid_max;
  p.photon_count = photon_count_;
  p.dims_x = layout_.dims[0];
  p.dims_y = layout_.dims[1];
  p.dims_z = layout_.dims[2];
  p.cell_count = layout_.cells();
  p.width = width_;
  p.height = height_;
  p.k = settings_.k;
  p.kernel = settings_.kernel;
  p.r_max = settings_.r_max;
  p.bin_width = settings_.bin_width;
  p.sparse = settings_.sparse;
  p.budget = settings_.budget;
  p.search = settings_.search;
  p.heap = settings_.heap;
  return p;
}

void KnnGrid::build(vk::CommandBuffer cmd, pb::gpu::Device& gpu, const pb::gpu::Buffer& photons,
                    std::span<const pb::trace::PhotonRecord> records) {
  layout_ = plan_grid(records, settings_);
  photon_count_ = uint32_t(records.size());
  photons_ = &photons;
  if (settings_.search == KNN_SEARCH_KDTREE) {
    // Seed 003's baseline: the tree built on the CPU (as the paper's, "prebuilt on the CPU") and
    // uploaded; the gather reads it where it reads the grid's photons. The grid's push fields
    // still bound the photons' box.
    const std::vector<KnnPhoton> tree = build_kdtree(records);
    const uint64_t bytes = std::max<uint64_t>(tree.size(), 1) * sizeof(KnnPhoton);
    if (!tree_ || tree_.size() < bytes)
      tree_ = pb::toolkit::storage_buffer(gpu, "knn/kdtree", bytes + bytes / 4,
                                          pb::gpu::Memory::host_visible);
    if (!tree.empty()) std::memcpy(tree_.mapped(), tree.data(), tree.size() * sizeof(KnnPhoton));
    return;
  }
  const uint64_t n = std::max<uint64_t>(photon_count_, 1);
  grow(gpu, items_, "knn/items", n * 8);
  grow(gpu, sorted_, "knn/sorted", n * 8);
  grow(gpu, compact_, "knn/photons-by-cell", n * sizeof(KnnPhoton));
  grow(gpu, cells_, "knn/cells", uint64_t(layout_.cells()) * 8);
  if (sort_.bins() < layout_.cells()) sort_.resize(gpu, scan_, layout_.cells(), "knn");
  // The sort's item count and its indirect dispatch, written before the submission.
  auto* args = static_cast<uint32_t*>(args_.mapped());
  args[0] = pb::gpu::groups_for(photon_count_, pb::toolkit::CountingSort::kGroupSize);
  args[1] = args[2] = 1;
  args[kArgsCountWord] = photon_count_;

  const KnnPush p = push();
  // The build kernels never touch the debug binding: stats_ stands in, so that a debug gather
  // recorded after this build may replace debug_ without leaving this recording a freed buffer.
  const std::vector<pb::gpu::Resource> list = {&photons,  &items_, &sorted_, &cells_,
                                               &compact_, &stats_, &stats_};
  cmd.fillBuffer(cells_.handle(), 0, uint64_t(layout_.cells()) * 8, 0u);
  cmd.fillBuffer(stats_.handle(), KNN_STAT_OCCUPIED * 4, 4, 0u);
  pb::gpu::full_barrier(cmd);
  keys_pipeline_.bind(cmd, list, p);
  cmd.dispatch(pb::gpu::groups_for(photon_count_, kGroup), 1, 1);
  pb::gpu::full_barrier(cmd);
  sort_.record(cmd, scan_, items_, sorted_, args_, kArgsCountWord, 0);
  pb::gpu::full_barrier(cmd);
  ranges_pipeline_.bind(cmd, list, p);
  cmd.dispatch(pb::gpu::groups_for(photon_count_, kGroup), 1, 1);
}

void KnnGrid::gather(vk::CommandBuffer cmd, pb::gpu::Device& gpu, const pb::GBuffer& gbuffer,
                     uint32_t width, uint32_t height, const pb::gpu::Image& indirect, bool debug) {
  width_ = width;
  height_ = height;
  KnnPush p = push();
  if (debug) {
    p.debug = 1;
    p.debug_stride = 2 + settings_.k;
    grow(gpu, debug_, "knn/debug", uint64_t(width) * height * p.debug_stride * 4);
  }
  const bool tree = settings_.search == KNN_SEARCH_KDTREE;
  if (settings_.heap == KNN_HEAP_GLOBAL)
    grow(gpu, heap_, "knn/heap", uint64_t(width) * height * settings_.k * 8);
  // The grid's buffers are empty with the kd-tree: the tree stands in for them (never read).
  std::vector<pb::gpu::Resource> list = {photons_,
                                         tree ? &tree_ : &items_,
                                         tree ? &tree_ : &sorted_,
                                         tree ? &tree_ : &cells_,
                                         tree ? &tree_ : &compact_,
                                         &stats_,
                                         &debug_};
  const auto g = pb::toolkit::gbuffer_resources(gbuffer);
  list.insert(list.end(), g.begin(), g.end());
  list.push_back(&indirect);
  list.push_back(&heap_);
  cmd.fillBuffer(stats_.handle(), 0, KNN_STAT_QUERY_WORDS * 4, 0u);
  cmd.fillBuffer(stats_.handle(), KNN_STAT_HEAP * 4, 8, 0u);
  if (debug) cmd.fillBuffer(debug_.handle(), 0, VK_WHOLE_SIZE, 0u);
  pb::gpu::full_barrier(cmd);
  gather_pipeline_.bind(cmd, list, p);
  cmd.dispatch(pb::gpu::groups_for(width, 8), pb::gpu::groups_for(height, 8), 1);
}

Stats KnnGrid::read_stats() const {
  auto s = stats_.view<uint32_t>();
  auto wide = [&](uint32_t at) { return uint64_t(s[at]) | (uint64_t(s[at + 1]) << 32); };
  Stats out;
  out.visited = wide(KNN_STAT_VISITED);
  out.cells_opened = wide(KNN_STAT_CELLS);
  out.found = wide(KNN_STAT_FOUND);
  out.heap_entries = wide(KNN_STAT_HEAP);
  out.queries = s[KNN_STAT_QUERIES];
  out.short_queries = s[KNN_STAT_SHORT];
  out.truncated = s[KNN_STAT_TRUNCATED];
  out.occupied = s[KNN_STAT_OCCUPIED];
  for (uint32_t b = 0; b < KNN_RADIUS_BINS; ++b) out.histogram[b] = s[KNN_STAT_HISTOGRAM + b];
  return out;
}

std::vector<KnnGrid::Query> KnnGrid::debug_queries(pb::gpu::Device& gpu) const {
  const uint32_t stride = 2 + settings_.k;
  std::vector<uint32_t> words(uint64_t(width_) * height_ * stride);
  gpu.download(debug_, words.data(), words.size() * 4);
  std::vector<Query> out(uint64_t(width_) * height_);
  for (size_t q = 0; q < out.size(); ++q) {
    const uint32_t* w = words.data() + q * stride;
    out[q].found = std::min(w[0], settings_.k);
    std::memcpy(&out[q].radius, &w[1], 4);
    out[q].photons.assign(w + 2, w + 2 + out[q].found);
  }
  return out;
}

uint64_t KnnGrid::bytes() const {
  return cells_.size() + items_.size() + sorted_.size() + compact_.size() + sort_.bytes() +
         scan_.scratch_bytes() + args_.size() + tree_.size() + heap_.size();
}

}  // namespace knn
