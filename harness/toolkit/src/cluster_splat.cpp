// ClusterSplat (photonbench/toolkit/cluster_splat.h).
#include "photonbench/toolkit/cluster_splat.h"

#include <fmt/format.h>

#include <algorithm>

#include "photonbench/error.h"
#include "toolkit_profiled_shaders.h"
#include "toolkit_shaders.h"

namespace pb::toolkit {

namespace {

// Mirrors the push block of harness/shaders/toolkit/cluster/cluster_common.glsl.
struct ClusterPush {
  glm::mat4 view;
  uint32_t photon_count = 0;
  float radius = 0;
  uint32_t flags = 0, top_level = 0, mode = 0, budget = 0, list_first = 0;
  float estimate_radius = 0;
  glm::vec4 units_per_watt{1.0f}, pad0{0.0f};
};
static_assert(sizeof(ClusterPush) == 128);

// Stats words (cluster_common.glsl).
constexpr uint32_t kClusterStatRead = 0, kClusterStatRejected = 2, kClusterStatTrivial = 4,
                   kClusterStatCone = 5, kClusterStatTruncated = 6, kClusterStatWords = 8;
constexpr uint32_t kClusterModeCount = 0, kClusterModeInsert = 1;

}  // namespace

void ClusterSplat::setup(Context& ctx, const Params& params, const PhotonParams& photon) {
  radius_ = photon.radius;
  options_ = kParams.read(params);
  top_levels_ = options_.top_levels;
  const uint32_t job_capacity = options_.max_jobs;
  const uint32_t list_capacity = options_.max_list_entries;
  auto& gpu = ctx.gpu();
  check_storage_range(gpu, uint64_t(job_capacity) * 8,
                      fmt::format("cluster: max_jobs = {} (8 bytes each)", job_capacity));
  check_storage_range(gpu, uint64_t(list_capacity) * 4,
                      fmt::format("cluster: max_list_entries = {} (4 bytes each)", list_capacity));
  auto layout = HierarchyOptions::named_layout(options_.layout);
  layout.normal_cones = options_.variant != kPlain;
  hierarchy_.setup(gpu, layout);
  // The top pass stops at the level above the leaves at the latest: leaves are stored, not walked.
  top_levels_ = std::min(top_levels_, hierarchy_.accumulation_level());

  scan_.setup(gpu);
  jobs_.setup(gpu, job_capacity, kJobsPerThread, "cluster");
  lists_.setup(gpu, list_capacity, "cluster");
  const bool profile = options_.profile;
  profile_.setup(gpu, {"top", "count", "insert"}, profile);
  stats_ = storage_buffer(gpu, "cluster/stats", kClusterStatWords * 4, gpu::Memory::host_visible);
  node_flux_.setup(gpu);

  auto B = gpu::Binding::storage_buffer;
  auto I = gpu::Binding::storage_image;
  std::vector<gpu::Binding> bindings(
      Hierarchy::kBindingCount + JobQueue::kBindingCount + PhotonLists::kBindingCount + 5, B);
  bindings.insert(bindings.end(), {I, I, I, I});
  constexpr uint32_t kPush = sizeof(ClusterPush);
  auto pick = [&](std::span<const uint32_t> plain, std::span<const uint32_t> profiled) {
    return profile ? profiled : plain;
  };
  top_pipeline_ = gpu.create_compute_pipeline(
      "splat/top", pick(kcluster_top_comp_spv, kcluster_top_comp_profiled_spv), bindings, kPush);
  leaf_pipeline_ = gpu.create_compute_pipeline(
      "splat/leaf", pick(kcluster_leaf_comp_spv, kcluster_leaf_comp_profiled_spv), bindings, kPush);
  estimate_pipeline_ =
      gpu.create_compute_pipeline("radiance-estimate", kcluster_estimate_comp_spv, bindings, kPush);
}

void ClusterSplat::ensure_resources(Context& ctx) {
  const auto& frame = ctx.frame();
  if (indirect_.extent().width == frame.width && indirect_.extent().height == frame.height) return;
  auto& gpu = ctx.gpu();
  const uint32_t nodes = hierarchy_.node_capacity();
  jobs_.resize(gpu, scan_, nodes);
  lists_.resize(gpu, scan_, nodes);
  // trivial: node flux for every level (a photon can be accepted at any node); else a placeholder.
  node_flux_.resize(gpu, hierarchy_, options_.variant == kTrivial ? hierarchy_.leaf_level() : 0,
                    options_.variant == kTrivial ? 3 : 0, "cluster/node-flux",
                    "cluster: node flux");
  indirect_ = gpu.create_image("cluster/indirect", {frame.width, frame.height},
                               vk::Format::eR32G32B32A32Sfloat, vk::ImageUsageFlagBits::eStorage);
}

const gpu::Image& ClusterSplat::render(Context& ctx, const PhotonSet& photons) {
  const auto& frame = ctx.frame();
  const FluxScale scale = FluxScale::for_photons(photons.records);
  hierarchy_.build(ctx);  // pass "cluster-build"; (re)allocates on a new resolution
  ensure_resources(ctx);

  ClusterPush push{};
  push.view = frame.camera.view;
  push.photon_count = photons.count();
  push.radius = radius_;
  push.flags = options_.variant;
  push.top_level = top_levels_;
  push.budget = options_.loop_budget;
  push.estimate_radius = radius_;
  push.units_per_watt = glm::vec4(scale.units_per_watt, 0.0f);

  std::vector<gpu::Resource> resources;
  hierarchy_.append_bindings(resources);
  jobs_.append_bindings(resources);
  lists_.append_bindings(resources);
  resources.insert(resources.end(), {photons.buffer, &node_flux_.lo(), &node_flux_.hi(), &stats_,
                                     &profile_.buffer()});
  auto g = gbuffer_resources(ctx.shared().gbuffer_images());
  resources.insert(resources.end(), g.begin(), g.end());
  resources.push_back(&indirect_);

  // ctx.cmd() is fetched anew in every pass: with fenced timing (lavapipe) a pass scope submits and
  // continues in a fresh command buffer.
  gpu::full_barrier(ctx.cmd());
  {
    auto splat = ctx.pass("splat");
    jobs_.record_top(ctx, scan_, [&](vk::CommandBuffer cmd) {
      cmd.fillBuffer(stats_.handle(), 0, VK_WHOLE_SIZE, 0u);
      node_flux_.clear(cmd);
      jobs_.clear(cmd);
      lists_.clear(cmd);
      profile_.clear(cmd);
      gpu::full_barrier(cmd);
      top_pipeline_.bind(cmd, resources, push);
      cmd.dispatch(std::max<uint32_t>(1, gpu::groups_for(photons.count(), 64)), 1, 1);
    });
    gpu::full_barrier(ctx.cmd());
    // The leaf passes, twice (Paper I §4.3).
    lists_.record_runs(ctx, scan_, [&](vk::CommandBuffer cmd, bool insert) {
      push.mode = insert ? kClusterModeInsert : kClusterModeCount;
      push.radius = insert ? radius_ * options_.insert_radius_scale : radius_;
      leaf_pipeline_.bind(cmd, resources, push);
      jobs_.dispatch_consumers(cmd);
    });
  }
  gpu::full_barrier(ctx.cmd());
  {
    auto scope = ctx.pass("radiance-estimate");
    auto cmd = ctx.cmd();
    if (options_.variant == kTrivial) {  // the node flux in watts for the estimate
      node_flux_.resolve(cmd, hierarchy_, scale);
      gpu::full_barrier(cmd);
    }
    dispatch_slices(cmd, photons.count(), [&](uint32_t first) {
      push.list_first = first;
      estimate_pipeline_.bind(cmd, resources, push);
      cmd.dispatch(gpu::groups_for(frame.width, 8), gpu::groups_for(frame.height, 8), 1);
    });
  }
  return indirect_;
}

void ClusterSplat::report(Context& ctx, const PhotonSet&) {
  auto s = stats_.view<uint32_t>();
  auto wide = [&](uint32_t at) { return double(uint64_t(s[at]) | (uint64_t(s[at + 1]) << 32)); };
  lists_.report(ctx, "cluster: per-node photon lists", "max_list_entries");
  jobs_.report(ctx, "cluster");
  report_truncated(ctx, "cluster", s[kClusterStatTruncated], options_.loop_budget);
  pb::count(ctx, kPhotonsReadCounter, wide(kClusterStatRead));
  pb::count(ctx, kPhotonsRejectedCounter, wide(kClusterStatRejected));
  if (options_.variant == kTrivial)
    pb::count(ctx, kTrivialAcceptsCounter, double(s[kClusterStatTrivial]));
  if (options_.variant != kPlain) pb::count(ctx, kConeRejectsCounter, double(s[kClusterStatCone]));
  uint64_t nodes = 0;
  for (uint32_t l = 0; l < hierarchy_.levels(); ++l) nodes += hierarchy_.occupied(l);
  pb::count(ctx, kHierarchyNodesCounter, double(nodes));
  pb::count(ctx, kHierarchyLeavesCounter, double(hierarchy_.occupied(hierarchy_.leaf_level())));
  // Memory per Paper I Table 1 row.
  pb::count(ctx, kBytesClusterHierarchyCounter, double(hierarchy_.bytes_hierarchy()));
  pb::count(ctx, kBytesFinalBoundsCounter, double(hierarchy_.bytes_final_bounds()));
  pb::count(ctx, kBytesNormalConeCounter, double(hierarchy_.bytes_normal_cone()));
  pb::count(ctx, kBytesAccumFluxCounter,
            options_.variant == kTrivial ? double(node_flux_.bytes()) : 0.0);
  pb::count(ctx, kBytesJobsCounter, double(jobs_.bytes()));
  pb::count(ctx, kBytesPhotonListsCounter, double(lists_.bytes() + scan_.scratch_bytes()));
  profile_.report(ctx);
}

}  // namespace pb::toolkit
