// DirectionalSplat (photonbench/toolkit/directional_splat.h).
#include "photonbench/toolkit/directional_splat.h"

#include <fmt/format.h>

#include <algorithm>

#include "photonbench/error.h"
#include "toolkit_profiled_shaders.h"
#include "toolkit_shaders.h"

namespace pb::toolkit {

namespace {

// Mirrors the push block of harness/shaders/toolkit/directional/directional_common.glsl.
struct DirPush {
  glm::mat4 view;
  glm::vec4 scale_radius;
  glm::vec4 inverse_area;
  glm::uvec4 counts;
  glm::uvec4 limits;
};
static_assert(sizeof(DirPush) == 128);

// Mirrors the push block of directional_blur.comp.
struct BlurPush {
  uint32_t width, height;
  int32_t radius;
  uint32_t axis;
  float depth_sigma, normal_sigma;
  uint32_t apply_brdf, pad0;
};

// Flags and stats words of directional_common.glsl.
constexpr uint32_t kFlagDepositPaper = 1, kFlagWeightClip = 2, kFlagDebugNormal = 4;
constexpr uint32_t kDirectionalStatDeposits = 0, kDirectionalStatTruncated = 2,
                   kDirectionalStatMissed = 3, kDirectionalStatWords = 4;
constexpr uint32_t kBucketWords = 24;  // 8 octants x RGB (Paper I §5.2: "24 floats per node")

}  // namespace

void DirectionalSplat::setup(Context& ctx, const Params& params, const PhotonParams& photon) {
  radius_ = photon.radius;
  options_ = kParams.read(params);
  top_levels_ = options_.top_levels;
  const bool profile = options_.profile;
  flags_ = (options_.deposit == Deposit::kPaper ? kFlagDepositPaper : 0u) |
           (options_.weighting == Weighting::kClip ? kFlagWeightClip : 0u) |
           (options_.debug_irradiance == DebugIrradiance::kNormal ? kFlagDebugNormal : 0u);
  const uint32_t job_capacity = options_.max_jobs;
  auto& gpu = ctx.gpu();
  check_storage_range(gpu, uint64_t(job_capacity) * 8,
                      fmt::format("directional: max_jobs = {} (8 bytes each)", job_capacity));
  // The hierarchy without normal cones (Paper I Table 1: "Normal Cone -" for directional).
  auto layout = HierarchyOptions::named_layout(options_.layout);
  layout.normal_cones = false;
  hierarchy_.setup(gpu, layout);
  top_levels_ = std::min(top_levels_, stop_level());

  scan_.setup(gpu);
  jobs_.setup(gpu, job_capacity, kJobsPerThread, "directional");
  profile_.setup(gpu, {"top", "deposit"}, profile);
  stats_ = storage_buffer(gpu, "directional/stats", kDirectionalStatWords * 4,
                          gpu::Memory::host_visible);
  flux_.setup(gpu);

  auto B = gpu::Binding::storage_buffer;
  auto I = gpu::Binding::storage_image;
  std::vector<gpu::Binding> bindings(Hierarchy::kBindingCount + JobQueue::kBindingCount + 6, B);
  bindings.insert(bindings.end(), {I, I, I, I});
  constexpr uint32_t kPush = sizeof(DirPush);
  leaf_counts_pipeline_ = gpu.create_compute_pipeline(
      "directional/leaf-counts", kdirectional_leaf_counts_comp_spv, bindings, kPush);
  auto pick = [&](std::span<const uint32_t> plain, std::span<const uint32_t> profiled) {
    return profile ? profiled : plain;
  };
  top_pipeline_ = gpu.create_compute_pipeline(
      "directional/top", pick(kdirectional_top_comp_spv, kdirectional_top_comp_profiled_spv),
      bindings, kPush);
  deposit_pipeline_ = gpu.create_compute_pipeline(
      "directional/deposit",
      pick(kdirectional_deposit_comp_spv, kdirectional_deposit_comp_profiled_spv), bindings, kPush);
  estimate_pipeline_ = gpu.create_compute_pipeline("directional/radiance-estimate",
                                                   kdirectional_estimate_comp_spv, bindings, kPush);
  blur_pipeline_ = gpu.create_compute_pipeline("directional/blur", kdirectional_blur_comp_spv,
                                               {I, I, I, I, I}, sizeof(BlurPush));
}

uint32_t DirectionalSplat::stop_level() const {
  return (options_.accumulate_at == AccumulateAt::kLeaves) ? hierarchy_.leaf_level()
                                                           : hierarchy_.accumulation_level();
}

void DirectionalSplat::ensure_resources(Context& ctx) {
  const auto& frame = ctx.frame();
  if (indirect_.extent().width == frame.width && indirect_.extent().height == frame.height) return;
  auto& gpu = ctx.gpu();
  width_ = frame.width;
  height_ = frame.height;
  // Buckets for every node from the roots down to the stop level, indexed by compact id: the
  // hierarchy hands out ids level by level, so those levels' ids are [0, end of the stop level).
  flux_.resize(
      gpu, hierarchy_, stop_level(), kBucketWords, "directional/accum-flux",
      fmt::format("directional: accumulate_at = {} at {}x{} (the direction buckets; use "
                  "accumulate_at = accumulation or a lower resolution)",
                  (options_.accumulate_at == AccumulateAt::kLeaves) ? "leaves" : "accumulation",
                  width_, height_));
  leaf_counts_ = storage_buffer(gpu, "directional/leaf-counts",
                                uint64_t(hierarchy_.node_capacity(hierarchy_.leaf_level())) * 16);
  jobs_.resize(gpu, scan_, hierarchy_.node_capacity());
  auto usage = vk::ImageUsageFlagBits::eStorage;
  auto format = vk::Format::eR32G32B32A32Sfloat;
  irradiance_ = gpu.create_image("directional/irradiance", {width_, height_}, format, usage);
  blur_tmp_ = gpu.create_image("directional/blur-x", {width_, height_}, format, usage);
  indirect_ = gpu.create_image("directional/indirect", {width_, height_}, format, usage);
}

const gpu::Image& DirectionalSplat::render(Context& ctx, const PhotonSet& photons) {
  const auto& frame = ctx.frame();
  const FluxScale scale = FluxScale::for_photons(photons.records);
  hierarchy_.build(ctx);  // pass "cluster-build"; (re)allocates on a new resolution
  ensure_resources(ctx);

  const uint32_t stop = stop_level();
  DirPush p{};
  p.view = frame.camera.view;
  p.scale_radius = glm::vec4(scale.units_per_watt, radius_);
  p.inverse_area = glm::vec4(scale.watts_per_unit, 1.0f / (3.14159265358979f * radius_ * radius_));
  p.counts = glm::uvec4(photons.count(), stop, flags_, top_levels_);
  p.limits = glm::uvec4(options_.loop_budget, width_, height_, 0);

  std::vector<gpu::Resource> resources;
  hierarchy_.append_bindings(resources);
  jobs_.append_bindings(resources);
  resources.insert(resources.end(), {photons.buffer, &flux_.lo(), &flux_.hi(), &leaf_counts_,
                                     &stats_, &profile_.buffer()});
  auto gbuf = ctx.shared().gbuffer_images();
  auto g = gbuffer_resources(gbuf);
  resources.insert(resources.end(), g.begin(), g.end());
  resources.push_back(&irradiance_);
  const uint32_t gx = gpu::groups_for(width_, 8), gy = gpu::groups_for(height_, 8);

  // ctx.cmd() is fetched anew in every pass: with fenced timing (lavapipe) a pass scope submits and
  // continues in a fresh command buffer.
  gpu::full_barrier(ctx.cmd());
  {
    auto splat = ctx.pass("splat");
    {
      auto scope = ctx.pass("leaf-counts");
      auto cmd = ctx.cmd();
      for (const gpu::Buffer* b : {&leaf_counts_, &stats_})
        cmd.fillBuffer(b->handle(), 0, VK_WHOLE_SIZE, 0u);
      flux_.clear(cmd);
      jobs_.clear(cmd);
      profile_.clear(cmd);
      gpu::full_barrier(cmd);
      if ((flags_ & kFlagDepositPaper) == 0) {  // the coverage estimate's weights
        leaf_counts_pipeline_.bind(cmd, resources, p);
        cmd.dispatch(gx, gy, 1);
      }
    }
    gpu::full_barrier(ctx.cmd());
    jobs_.record_top(ctx, scan_, [&](vk::CommandBuffer cmd) {
      top_pipeline_.bind(cmd, resources, p);
      cmd.dispatch(std::max<uint32_t>(1, gpu::groups_for(photons.count(), 64)), 1, 1);
    });
    gpu::full_barrier(ctx.cmd());
    {
      auto scope = ctx.pass("deposit");
      auto cmd = ctx.cmd();
      deposit_pipeline_.bind(cmd, resources, p);
      jobs_.dispatch_consumers(cmd);
    }
  }
  gpu::full_barrier(ctx.cmd());
  {
    auto scope = ctx.pass("radiance-estimate");
    auto cmd = ctx.cmd();
    flux_.resolve(cmd, hierarchy_, scale);  // the buckets in watts for the estimate
    gpu::full_barrier(cmd);
    estimate_pipeline_.bind(cmd, resources, p);
    cmd.dispatch(gx, gy, 1);
  }
  gpu::full_barrier(ctx.cmd());
  {
    auto scope = ctx.pass("blur");
    auto cmd = ctx.cmd();
    // The blockiness the blur hides has the size of a stop-level node (Paper I §4.7).
    const int32_t radius = options_.blur_radius >= 0
                               ? options_.blur_radius
                               : int32_t(hierarchy_.node_footprint_px(stop) / 2);
    blur_taps_ = radius;
    BlurPush push{width_, height_, radius, 0, options_.blur_depth_sigma, options_.blur_normal_sigma,
                  0,      0};
    const gpu::Image* source = &irradiance_;
    if (radius > 0) {
      blur_pipeline_.bind(cmd, {gbuf.position, gbuf.normal, gbuf.albedo, &irradiance_, &blur_tmp_},
                          push);
      cmd.dispatch(gx, gy, 1);
      gpu::full_barrier(cmd);
      source = &blur_tmp_;
    }
    // Along y, then the diffuse BRDF: radiance = albedo / pi * E (Paper I §4.7).
    push.axis = 1;
    push.apply_brdf = 1;
    blur_pipeline_.bind(cmd, {gbuf.position, gbuf.normal, gbuf.albedo, source, &indirect_}, push);
    cmd.dispatch(gx, gy, 1);
  }
  return indirect_;
}

void DirectionalSplat::report(Context& ctx, const PhotonSet&) {
  auto s = stats_.view<uint32_t>();
  pb::count(ctx, kNodeDepositsCounter,
            double(uint64_t(s[kDirectionalStatDeposits]) |
                   (uint64_t(s[kDirectionalStatDeposits + 1]) << 32)));
  pb::count(ctx, kPhotonsMissedCounter, double(s[kDirectionalStatMissed]));
  jobs_.report(ctx, "directional");
  report_truncated(ctx, "directional", s[kDirectionalStatTruncated], options_.loop_budget);
  pb::count(ctx, kBytesClusterHierarchyCounter, double(hierarchy_.bytes_hierarchy()));
  pb::count(ctx, kBytesFinalBoundsCounter, double(hierarchy_.bytes_final_bounds()));
  pb::count(ctx, kBytesAccumFluxCounter, double(flux_.bytes()));
  pb::count(ctx, kBytesLeafCountsCounter, double(leaf_counts_.size()));
  pb::count(ctx, kBytesJobsCounter, double(jobs_.bytes()));
  pb::count(ctx, kBlurRadiusCounter, double(blur_taps_));
  profile_.report(ctx);
}

}  // namespace pb::toolkit
