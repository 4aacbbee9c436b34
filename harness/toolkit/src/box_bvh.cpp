// BoxBvh (photonbench/toolkit/box_bvh.h).
#include "photonbench/toolkit/box_bvh.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "photonbench/error.h"
#include "photonbench/toolkit/limits.h"
#include "photonbench/toolkit/technique.h"
#include "toolkit_shaders.h"

namespace pb::toolkit {

namespace {
constexpr uint32_t kGroup = 256;
}  // namespace

BvhBox cylinder_box(glm::vec3 centre, glm::vec3 normal, float radius, float height) {
  // Per axis k: the disc of radius r about the axis n reaches r sqrt(1 - n_k^2), the axis
  // h/2 |n_k|.
  const glm::vec3 n = glm::normalize(normal);
  const glm::vec3 extent = radius * glm::sqrt(glm::max(glm::vec3(1.0f) - n * n, glm::vec3(0.0f))) +
                           0.5f * height * glm::abs(n);
  BvhBox box{};
  box.lo = centre - extent;
  box.hi = centre + extent;
  return box;
}

void BoxBvh::setup(gpu::Device& gpu, std::string_view name, bool host_readable) {
  gpu_ = &gpu;
  name_ = std::string(name);
  host_readable_ = host_readable;
  sort_.setup(gpu, name_ + "/morton");
  scan_.setup(gpu);
  const std::vector<gpu::Binding> bindings(8, gpu::Binding::storage_buffer);
  auto make = [&](const char* pass, std::span<const uint32_t> spirv) {
    return gpu.create_compute_pipeline(name_ + "/" + pass, spirv, bindings, sizeof(BvhPush));
  };
  bounds_ = make("bounds", kbvh_bounds_comp_spv);
  morton_ = make("morton", kbvh_morton_comp_spv);
  heads_pipeline_ = make("heads", kbvh_heads_comp_spv);
  runs_ = make("runs", kbvh_runs_comp_spv);
  karras_ = make("hierarchy", kbvh_karras_comp_spv);
  bottom_up_ = make("bottom-up", kbvh_bottomup_comp_spv);
  const std::vector<gpu::Binding> refit_bindings(9, gpu::Binding::storage_buffer);
  refit_gather_ = gpu.create_compute_pipeline(name_ + "/refit-gather", kbvh_refit_gather_comp_spv,
                                              refit_bindings, sizeof(BvhPush));
  refit_leaves_ = gpu.create_compute_pipeline(name_ + "/refit-leaves", kbvh_refit_leaves_comp_spv,
                                              refit_bindings, sizeof(BvhPush));
  probe_ = gpu.create_compute_pipeline(name_ + "/probe", kbvh_probe_comp_spv,
                                       std::vector<gpu::Binding>(7, gpu::Binding::storage_buffer),
                                       8 * sizeof(uint32_t));
  control_ =
      storage_buffer(gpu, name_ + "/control", PB_BVH_CTL_WORDS * 4, gpu::Memory::host_visible);
  reserve(1024);
}

void BoxBvh::reserve(uint32_t count) {
  if (count <= capacity_ && nodes_) return;
  capacity_ = std::max<uint32_t>(1024, std::max(count, capacity_ + capacity_ / 2));
  built_count_ = 0;  // the tree goes with the buffers
  refit_bounds_ = {};
  const uint64_t n = capacity_;
  const auto readable = host_readable_ ? gpu::Memory::host_visible : gpu::Memory::device_local;
  auto buffer = [&](const char* what, uint64_t bytes, gpu::Memory memory) {
    check_storage_range(*gpu_, bytes, fmt::format("{}: {} boxes", name_, count));
    return storage_buffer(*gpu_, name_ + "/" + what, bytes, memory);
  };
  keys_ = buffer("keys", n * 4, gpu::Memory::device_local);
  items_ = buffer("items", n * 4, readable);
  heads_ = buffer("heads", n * 4, gpu::Memory::device_local);
  run_index_ = buffer("run-index", n * 4, gpu::Memory::device_local);
  unique_ = buffer("unique-keys", n * 4, gpu::Memory::device_local);
  nodes_ = buffer("nodes", 2 * n * sizeof(BvhNode), readable);
  sort_.reserve(capacity_);
  scan_.reserve(capacity_);
}

void BoxBvh::record_build(vk::CommandBuffer cmd, const gpu::Buffer& boxes, uint32_t count) {
  if (count > capacity_)
    throw Error(
        fmt::format("{}: a build over {} boxes, only {} reserved", name_, count, capacity_));
  const std::vector<gpu::Resource> resources = {&boxes,      &keys_,   &items_, &heads_,
                                                &run_index_, &unique_, &nodes_, &control_};
  BvhPush push{count, 0, PB_LOOP_BUDGET, 0};
  const uint32_t groups = gpu::groups_for(count, kGroup);
  auto dispatch = [&](const gpu::Pipeline& pipeline) {
    if (groups == 0) return;
    pipeline.bind(cmd, std::span<const gpu::Resource>(resources), push);
    cmd.dispatch(groups, 1, 1);
    gpu::full_barrier(cmd);
  };
  cmd.fillBuffer(control_.handle(), 0, VK_WHOLE_SIZE, 0u);
  gpu::full_barrier(cmd);
  cmd.fillBuffer(control_.handle(), 0, 3 * sizeof(uint32_t), 0xffffffffu);  // the minima
  cmd.fillBuffer(control_.handle(), PB_BVH_CTL_COUNT * 4, 4, count);
  gpu::full_barrier(cmd);
  built_count_ = count;
  if (count == 0) return;  // runs stays 0: every walk finds nothing
  dispatch(bounds_);
  dispatch(morton_);
  sort_.record(cmd, keys_, items_, count, kMortonBits);
  gpu::full_barrier(cmd);
  dispatch(heads_pipeline_);
  scan_.record(cmd, heads_, run_index_, count, &control_, PB_BVH_CTL_RUNS);
  gpu::full_barrier(cmd);
  dispatch(runs_);
  dispatch(karras_);
  for (uint32_t pass = 1; pass <= kBottomUpPasses; ++pass) {
    push.pass = pass;
    dispatch(bottom_up_);
  }
}

void BoxBvh::record_refit(vk::CommandBuffer cmd, const gpu::Buffer& boxes, uint32_t count) {
  if (!can_refit(count))
    throw Error(
        fmt::format("{}: a refit over {} boxes needs a build over as many first (built: {})", name_,
                    count, built_count_));
  const uint64_t bound_bytes = uint64_t(capacity_) * 6 * sizeof(uint32_t);
  if (refit_bounds_.size() < bound_bytes) {
    check_storage_range(*gpu_, bound_bytes, fmt::format("{}: {} boxes", name_, count));
    refit_bounds_ =
        storage_buffer(*gpu_, name_ + "/refit-bounds", bound_bytes, gpu::Memory::device_local);
  }
  const std::vector<gpu::Resource> resources = {&boxes,      &keys_,   &items_, &heads_,
                                                &run_index_, &unique_, &nodes_, &control_};
  std::vector<gpu::Resource> refit_resources = resources;
  refit_resources.push_back(&refit_bounds_);
  BvhPush push{count, 0, PB_LOOP_BUDGET, 0};
  const uint32_t groups = gpu::groups_for(count, kGroup);
  auto dispatch = [&](const gpu::Pipeline& pipeline, const std::vector<gpu::Resource>& bound) {
    pipeline.bind(cmd, std::span<const gpu::Resource>(bound), push);
    cmd.dispatch(groups, 1, 1);
    gpu::full_barrier(cmd);
  };
  // All ones: the minima's start, and the maxima's, which the gather keeps complemented.
  cmd.fillBuffer(refit_bounds_.handle(), 0, uint64_t(count) * 6 * sizeof(uint32_t), 0xffffffffu);
  cmd.fillBuffer(control_.handle(), PB_BVH_CTL_INNER * 4, 4, 0u);
  cmd.fillBuffer(control_.handle(), PB_BVH_CTL_LONG_RUNS * 4, 4, 0u);  // a refit cuts no run
  gpu::full_barrier(cmd);
  dispatch(refit_gather_, refit_resources);
  dispatch(refit_leaves_, refit_resources);
  for (uint32_t pass = 1; pass <= kBottomUpPasses; ++pass) {
    push.pass = pass;
    dispatch(bottom_up_, resources);
  }
}

std::array<gpu::Resource, 4> BoxBvh::walk_resources(const gpu::Buffer& boxes) const {
  return {&nodes_, &items_, &boxes, &control_};
}

BoxBvh::Stats BoxBvh::read_stats() const {
  const auto* c = static_cast<const uint32_t*>(control_.mapped());
  Stats s;
  s.items = c[PB_BVH_CTL_COUNT];
  s.leaves = s.items > 0 ? c[PB_BVH_CTL_RUNS] : 0;
  s.inner = c[PB_BVH_CTL_INNER];
  s.long_runs = c[PB_BVH_CTL_LONG_RUNS];
  return s;
}

uint64_t BoxBvh::bytes() const {
  uint64_t b = sort_.bytes() + scan_.scratch_bytes() + control_.size() + refit_bounds_.size();
  for (const gpu::Buffer* x : {&keys_, &items_, &heads_, &run_index_, &unique_, &nodes_})
    b += x->size();
  return b;
}

void BoxBvh::record_probe(vk::CommandBuffer cmd, const gpu::Buffer& boxes,
                          const gpu::Buffer& queries, uint32_t count, const gpu::Buffer& found,
                          const gpu::Buffer& counts, uint32_t per_query, uint32_t budget,
                          uint32_t leaf_size, bool test_item_boxes) const {
  const std::array<uint32_t, 8> push = {
      count, per_query, budget, leaf_size, test_item_boxes ? 1u : 0u, 0, 0, 0};
  const std::vector<gpu::Resource> resources = {&queries, &found, &counts,  &nodes_,
                                                &items_,  &boxes, &control_};
  probe_.bind(cmd, std::span<const gpu::Resource>(resources), push);
  cmd.dispatch(gpu::groups_for(count, 64), 1, 1);
  gpu::full_barrier(cmd);
}

}  // namespace pb::toolkit
