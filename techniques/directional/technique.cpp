// directional: Paper I's directional approximation (Moreau et al. 2016, §4.7, §5.1, §5.2): photons
// are splatted into the view-sample cluster hierarchy, but instead of per-node photon lists each
// node of the accumulation level (one above the leaves, Paper I's "level 4") and above keeps the
// flux that reaches it in eight direction buckets (the octants of the incident direction in view
// space); each view sample then sums its containing nodes' buckets, weighted by the tangent-plane
// heuristic 2cos(n, d), into an irradiance texture, which a depth- and normal-aware blur smooths
// before the diffuse BRDF turns it into the indirect radiance the shared shade pass adds.
//
// Per frame: photon-trace / photon-upload (as tiled), gbuffer, direct-light, cluster-build (the
// hierarchy of techniques/cluster, shared with the cluster technique), splat, radiance-estimate,
// blur, shade. An intersected (not enclosed) node receives the photon's flux times the share of its
// samples inside the sphere, not the whole flux as Paper I's text has it (parameter `deposit`;
// README: deviations).
#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <glm/glm.hpp>

#include "directional_shaders.h"
#include "hierarchy.h"
#include "photonbench/context.h"
#include "photonbench/error.h"
#include "photonbench/plugin.h"

namespace {

using pb::gpu::Binding;
using pb::gpu::Buffer;
using pb::gpu::Memory;
using U = vk::BufferUsageFlagBits;

// `layout` names one of the cluster hierarchy's layouts (pb::cluster::HierarchyOptions::named_layout,
// techniques/cluster/README.md "Hierarchy layout"), so a sweep compares the two techniques on the same
// hierarchy. Each keeps the level above the leaves at 32x32 pixels.
const pb_param_spec kParams[] = {
    {"photons", PB_PARAM_INT, 100000, 1, 5e7, nullptr, "paths",
     "light paths traced per frame (as tiled; Paper I counts stored photons)"},
    {"radius", PB_PARAM_FLOAT, 0.05, 1e-5, 1e4, nullptr, "m", "photon sphere radius; default 0.05"},
    {"max_bounces", PB_PARAM_INT, 4, 2, 31, nullptr, "hits",
     "surface interactions per light path; Paper I §4.2 limits tracing to four bounces"},
    {"shadow_map_size", PB_PARAM_INT, 512, 16, 4096, nullptr, "texels",
     "shadow-map tile side of the direct light"},
    {"deposit", PB_PARAM_ENUM, 0, 0, 1, "coverage|paper", "",
     "flux an intersected (not enclosed) accumulation-level node receives: coverage = the photon's "
     "flux times the share of the node's leaf clusters inside its sphere; paper = the whole flux"},
    {"weighting", PB_PARAM_ENUM, 0, 0, 1, "cos2|clip", "",
     "octant weight at a sample: cos2 = Paper I's max(0, 2cos(n, d)); clip = share of the octant "
     "above the tangent plane (the correction Paper I describes and approximates)"},
    {"layout", PB_PARAM_ENUM, 0, 0, 2, "default|shallow|deep", "",
     "hierarchy layout, as the cluster technique's (README)"},
    {"accumulate_at", PB_PARAM_ENUM, 0, 0, 1, "accumulation|leaves", "",
     "lowest level with buckets: accumulation = one above the leaves (Paper I's level 4, "
     "default); leaves = the leaf clusters (finer, Paper I §5.2 sizes buckets down to them)"},
    {"blur_radius", PB_PARAM_INT, -1, -1, 64, nullptr, "pixels",
     "taps on each side of the separable depth/normal-aware blur; 0 turns the blur off; -1 "
     "(default) "
     "= half the screen side of a stop-level node (16 for the 32-pixel accumulation level)"},
    {"blur_depth_sigma", PB_PARAM_FLOAT, 0.02, 1e-6, 1e6, nullptr, "",
     "blur depth awareness: distance from the tangent plane, relative to the camera distance"},
    {"blur_normal_sigma", PB_PARAM_FLOAT, 0.2, 1e-6, 1e6, nullptr, "rad",
     "blur normal awareness: angle between the normals"},
    {"max_visits", PB_PARAM_INT, 1024, 1, 1 << 20, nullptr, "nodes",
     "hierarchy nodes one photon may visit in the splat; more are dropped and counted (overflows), "
     "which keeps an invocation under llvmpipe's loop limit"},
    {"debug_irradiance", PB_PARAM_ENUM, 0, 0, 1, "photons|normal", "",
     "test hook: normal = irradiance is |world normal| instead of the photon estimate (checks "
     "that the blur keeps surfaces apart)"},
};

// Mirrors DirParams of shaders/directional_common.h, the push constants of every pass but the blur
// (std430: mat4, vec4, two uvec4).
struct DirParams {
  glm::mat4 view;
  glm::vec4 radius;
  glm::uvec4 counts;
  glm::uvec4 size;
};
static_assert(sizeof(DirParams) == 112);

// Mirrors the push block of shaders/blur.comp.
struct BlurPush {
  uint32_t width, height;
  int32_t radius;
  uint32_t axis;
  float depth_sigma, normal_sigma;
  uint32_t apply_brdf, pad0;
};

// Flags and stats words of shaders/directional_common.h.
constexpr uint32_t kFlagDepositPaper = 1, kFlagWeightClip = 2, kFlagDebugNormal = 4;
constexpr uint32_t kStatDeposits = 0, kStatOverflows = 2, kStatMissed = 3, kStatWords = 8;
constexpr uint32_t kBucketFloats = 24;  // 8 octants x RGB (Paper I §5.2: "24 floats per node")

class Directional final : public pb::Technique {
 public:
  void setup(pb::Context& ctx, const pb::Params& params) override {
    paths_ = uint32_t(params.integer("photons"));
    radius_ = float(params.number("radius"));
    max_bounces_ = uint32_t(params.integer("max_bounces"));
    max_visits_ = uint32_t(params.integer("max_visits"));
    blur_radius_ = int32_t(params.integer("blur_radius"));
    blur_depth_sigma_ = float(params.number("blur_depth_sigma"));
    blur_normal_sigma_ = float(params.number("blur_normal_sigma"));
    flags_ = (params.choice("deposit") == "paper" ? kFlagDepositPaper : 0u) |
             (params.choice("weighting") == "clip" ? kFlagWeightClip : 0u) |
             (params.choice("debug_irradiance") == "normal" ? kFlagDebugNormal : 0u);
    at_leaves_ = params.choice("accumulate_at") == "leaves";
    ctx.shared().configure_shadows(uint32_t(params.integer("shadow_map_size")), 0.01f, 0.01f);
    // The hierarchy without normal cones (Paper I Table 1: "Normal Cone -" for directional).
    const std::string& layout = params.choice("layout");
    auto options = pb::cluster::HierarchyOptions::named_layout(layout);
    options.normal_cones = false;
    hierarchy_.setup(ctx.gpu(), options);

    auto& gpu = ctx.gpu();
    auto B = Binding::storage_buffer;
    auto I = Binding::storage_image;
    auto with_hierarchy = [](std::vector<Binding> own) {
      for (uint32_t i = 0; i < pb::cluster::Hierarchy::kBindingCount; ++i)
        own.push_back(Binding::storage_buffer);
      return own;
    };
    leaf_counts_pipeline_ = gpu.create_compute_pipeline(
        "directional/leaf-counts", kleaf_counts_comp_spv,
        [&] {
          auto b = with_hierarchy({B});
          b.push_back(I);
          return b;
        }(),
        sizeof(DirParams));
    splat_pipeline_ = gpu.create_compute_pipeline("directional/splat", ksplat_comp_spv,
                                                  with_hierarchy({B, B, B, B}), sizeof(DirParams));
    estimate_pipeline_ =
        gpu.create_compute_pipeline("directional/radiance-estimate", kradiance_estimate_comp_spv,
                                    with_hierarchy({B, I, I, I, I}), sizeof(DirParams));
    blur_pipeline_ = gpu.create_compute_pipeline("directional/blur", kblur_comp_spv,
                                                 {I, I, I, I, I}, sizeof(BlurPush));
    stats_ = gpu.create_buffer("directional/stats", kStatWords * 4,
                               U::eStorageBuffer | U::eTransferDst, Memory::host_visible);
  }

  void render(pb::Context& ctx) override {
    auto& gpu = ctx.gpu();
    const auto& frame = ctx.frame();
    pb::trace::TraceSettings settings;
    settings.paths = paths_;
    settings.max_bounces = max_bounces_;
    // As tiled: every diffuse hit but the first (Paper I §4.2), without pure caustics L S+ D,
    // which the `indirect` path class excludes.
    settings.store = pb::trace::kIndirectPhotons | pb::trace::kCausticIndirectPhotons;
    const uint32_t photon_count =
        pb::trace_and_upload_photons(ctx, settings, batch_, photons_, "directional/photons");
    {
      // Fixed-point scale of the buckets (shaders/directional_common.h): no bucket can exceed the
      // largest channel's total flux.
      glm::dvec3 total(0.0);
      for (const auto& photon : batch_.photons) total += glm::dvec3(photon.power);
      double largest = std::max({total.x, total.y, total.z, 1e-30});
      flux_scale_ = float(4.0e9 / largest);
    }
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    hierarchy_.build(ctx);  // pass "cluster-build"; (re)allocates on a new resolution
    ensure_resources(ctx);

    uint32_t stop = stop_level();
    DirParams p{};
    p.view = frame.camera.view;
    p.radius = glm::vec4(radius_, 1.0f / (3.14159265358979f * radius_ * radius_), flux_scale_,
                         1.0f / flux_scale_);
    p.counts = glm::uvec4(photon_count, stop, flags_, max_visits_);
    p.size = glm::uvec4(width_, height_, 0, 0);

    auto h = hierarchy_.bindings();
    auto gbuf = ctx.shared().gbuffer_images();
    // ctx.cmd() is fetched anew in every pass: with fenced timing (lavapipe) a pass scope submits
    // and continues in a fresh command buffer.
    pb::gpu::full_barrier(ctx.cmd());
    {
      auto splat = ctx.pass("splat");
      {
        auto scope = ctx.pass("leaf-counts");
        auto cmd = ctx.cmd();
        cmd.fillBuffer(leaf_counts_.handle(), 0, VK_WHOLE_SIZE, 0u);
        cmd.fillBuffer(flux_.handle(), 0, VK_WHOLE_SIZE, 0u);
        cmd.fillBuffer(stats_.handle(), 0, VK_WHOLE_SIZE, 0u);
        pb::gpu::full_barrier(cmd);
        if ((flags_ & kFlagDepositPaper) == 0) {  // the coverage estimate's weights
          leaf_counts_pipeline_.bind(
              cmd, {&leaf_counts_, h[0], h[1], h[2], h[3], h[4], h[5], h[6], gbuf.position}, p);
          cmd.dispatch(pb::gpu::groups_for(width_, 8), pb::gpu::groups_for(height_, 8), 1);
        }
      }
      pb::gpu::full_barrier(ctx.cmd());
      {
        auto scope = ctx.pass("deposit");
        auto cmd = ctx.cmd();
        splat_pipeline_.bind(
            cmd,
            {&photons_, &flux_, &leaf_counts_, &stats_, h[0], h[1], h[2], h[3], h[4], h[5], h[6]},
            p);
        if (photon_count) cmd.dispatch(pb::gpu::groups_for(photon_count, 64), 1, 1);
      }
    }
    pb::gpu::full_barrier(ctx.cmd());
    {
      auto scope = ctx.pass("radiance-estimate");
      auto cmd = ctx.cmd();
      estimate_pipeline_.bind(cmd,
                              {&flux_, gbuf.position, gbuf.normal, gbuf.albedo, &irradiance_, h[0],
                               h[1], h[2], h[3], h[4], h[5], h[6]},
                              p);
      cmd.dispatch(pb::gpu::groups_for(width_, 8), pb::gpu::groups_for(height_, 8), 1);
    }
    pb::gpu::full_barrier(ctx.cmd());
    {
      auto scope = ctx.pass("blur");
      auto cmd = ctx.cmd();
      // The blockiness the blur hides has the size of a stop-level node (Paper I §4.7).
      int32_t radius =
          blur_radius_ >= 0 ? blur_radius_ : int32_t(hierarchy_.node_footprint_px(stop) / 2);
      BlurPush push{width_, height_, radius, 0, blur_depth_sigma_, blur_normal_sigma_, 0, 0};
      const pb::gpu::Image* source = &irradiance_;
      if (radius > 0) {
        blur_pipeline_.bind(
            cmd, {gbuf.position, gbuf.normal, gbuf.albedo, &irradiance_, &blur_tmp_}, push);
        cmd.dispatch(pb::gpu::groups_for(width_, 8), pb::gpu::groups_for(height_, 8), 1);
        pb::gpu::full_barrier(cmd);
        source = &blur_tmp_;
      }
      // Along y, then the diffuse BRDF: radiance = albedo / pi * E (Paper I §4.7).
      push.axis = 1;
      push.apply_brdf = 1;
      blur_pipeline_.bind(cmd, {gbuf.position, gbuf.normal, gbuf.albedo, source, &indirect_}, push);
      cmd.dispatch(pb::gpu::groups_for(width_, 8), pb::gpu::groups_for(height_, 8), 1);
    }
    pb::gpu::full_barrier(ctx.cmd());
    ctx.shared().shade(&indirect_);

    // The counters live on the GPU: wait for the frame's work (flush makes them host-visible).
    ctx.flush();
    report(ctx, photon_count);
  }

 private:
  // Per-resolution resources, made on the first frame (the frame size is known from render on).
  void ensure_resources(pb::Context& ctx) {
    const auto& frame = ctx.frame();
    if (indirect_.extent().width == frame.width && indirect_.extent().height == frame.height)
      return;
    auto& gpu = ctx.gpu();
    width_ = frame.width;
    height_ = frame.height;
    // Buckets for every node from the roots down to the stop level, indexed by compact id: the
    // hierarchy hands out ids level by level, so those levels' ids are [0, end of the stop level).
    uint32_t stop = stop_level();
    bucket_nodes_ = hierarchy_.first_cid(stop) + hierarchy_.node_capacity(stop);
    uint32_t leaves = hierarchy_.node_capacity(hierarchy_.leaf_level());
    uint64_t flux_bytes = uint64_t(bucket_nodes_) * kBucketFloats * 4;
    uint64_t limit = gpu.physical().getProperties().limits.maxStorageBufferRange;
    if (flux_bytes > limit)
      throw pb::InputError(fmt::format(
          "directional: accumulate_at = {} at {}x{} needs {} bytes of direction buckets, more than "
          "the device's maxStorageBufferRange ({}); use accumulate_at = accumulation or a lower "
          "resolution",
          at_leaves_ ? "leaves" : "accumulation", width_, height_, flux_bytes, limit));
    auto storage = U::eStorageBuffer | U::eTransferDst;
    flux_ = gpu.create_buffer("directional/accum-flux", flux_bytes, storage, Memory::device_local);
    leaf_counts_ = gpu.create_buffer("directional/leaf-counts", uint64_t(leaves) * 16, storage,
                                     Memory::device_local);
    auto usage = vk::ImageUsageFlagBits::eStorage;
    auto format = vk::Format::eR32G32B32A32Sfloat;
    irradiance_ = gpu.create_image("directional/irradiance", {width_, height_}, format, usage);
    blur_tmp_ = gpu.create_image("directional/blur-x", {width_, height_}, format, usage);
    indirect_ = gpu.create_image("directional/indirect", {width_, height_}, format, usage);
  }

  uint32_t stop_level() const {
    return at_leaves_ ? hierarchy_.leaf_level() : hierarchy_.accumulation_level();
  }

  void report(pb::Context& ctx, uint32_t photon_count) {
    auto s = stats_.view<uint32_t>();
    double deposits = double(uint64_t(s[kStatDeposits]) | (uint64_t(s[kStatDeposits + 1]) << 32));
    uint32_t overflows = s[kStatOverflows];
    ctx.count("node_deposits", deposits);
    ctx.count("photons_rejected", s[kStatMissed]);
    ctx.count("overflows", overflows);
    ctx.count("bytes_cluster_hierarchy", double(hierarchy_.bytes_hierarchy()));
    ctx.count("bytes_final_bounds", double(hierarchy_.bytes_final_bounds()));
    ctx.count("bytes_accum_flux", double(flux_.size()));
    ctx.count("bytes_leaf_counts", double(leaf_counts_.size()));
    ctx.count("bytes_photons", double(uint64_t(photon_count) * sizeof(pb::trace::PhotonRecord)));
    if (overflows > 0)
      ctx.warn(fmt::format(
          "directional: {} photons needed more than max_visits = {} hierarchy nodes (or llvmpipe's "
          "loop budget) in the splat; the rest of their deposits were dropped",
          overflows, max_visits_));
  }

  uint32_t paths_ = 0, max_bounces_ = 4, max_visits_ = 1024, flags_ = 0;
  bool at_leaves_ = false;
  float radius_ = 0, flux_scale_ = 1, blur_depth_sigma_ = 0.02f, blur_normal_sigma_ = 0.2f;
  int32_t blur_radius_ = -1;
  uint32_t width_ = 0, height_ = 0, bucket_nodes_ = 0;
  pb::cluster::Hierarchy hierarchy_;
  pb::trace::PhotonBatch batch_;
  Buffer photons_, flux_, leaf_counts_, stats_;
  pb::gpu::Image irradiance_, blur_tmp_, indirect_;
  pb::gpu::Pipeline leaf_counts_pipeline_, splat_pipeline_, estimate_pipeline_, blur_pipeline_;
};

}  // namespace

PB_EXPORT_TECHNIQUE(
    Directional, "directional", "indirect",
    "Paper I's directional approximation: photons splatted into the view-sample cluster hierarchy "
    "accumulate flux per node in 8 view-space octant buckets; per-sample 2cos-weighted irradiance, "
    "depth- and normal-aware blur",
    kParams)
