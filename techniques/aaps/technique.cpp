// aaps: adaptive anisotropic photon scattering (Yang & Ouyang 2021, as re-implemented and settled
// in seed 004, van Casteren 2023), with the thesis's MSAA variants (§5.1). Per frame:
//   photon-trace  the CPU tracer emits each light's task buffer (photon_rules.h: a grid of
//                 floor(sqrt(D))^2 photons per density texel, first hit a dielectric, split once
//                 then repeat, stored at the first diffuse hit); each stored photon's two
//                 differentials give an ellipse, clamped in anisotropy, culled outside the frustum
//                 and above the solid-angle threshold; accepted ones become two-triangle quads;
//   rasterize     the quads drawn with additive blending into a screen-sized caustics buffer,
//                 clipped to the ellipse and depth-tested against the G-buffer in the fragment
//                 shader (brightness = energy / ellipse area); per-sample variants into a
//                 multisampled buffer;
//   apply         the multisampled buffer resolved, caustic irradiance to radiance on diffuse
//                 receivers, handed to shade();
//   task-update   variance by reprojection, density D' = D A / A_t + v g with the spatio-temporal
//                 blend, the sum quadtree of the next frame's emission.
// With indirect: splat_bvh (§5.2), caustics seen through mirrors and glass: splats outside the
// frustum are kept for it, the toolkit's box BVH is rebuilt over every splat's quad (splat-bvh),
// and each pixel whose camera path passed S vertices walks its last segment against it, the
// fragment shader's ellipse test as the any-hit (indirect, aaps_indirect.comp).
// README.md gives the parameters, every constant the thesis leaves open and the deviations.
#include "photonbench/toolkit/technique.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <glm/glm.hpp>
#include <iterator>
#include <string>
#include <vector>

#include "aaps_shaders.h"
#include "footprint.h"
#include "photon_rules.h"
#include "photonbench/error.h"
#include "photonbench/plugin.h"
#include "photonbench/scene_layout.h"
#include "photonbench/toolkit/box_bvh.h"
#include "splat_bvh.h"
#include "task_buffer.h"

namespace {

using pb::gpu::Binding;

// The choices of the enumerated parameters, in their declared order.
enum class Msaa : uint32_t { none, all, all_per_sample, small_per_sample };
enum class FeedbackHalves : uint32_t { both, refracted };
enum class Indirect : uint32_t { none, splat_bvh };

// Every parameter of a cell: the density feedback's (task_buffer.h, whose initialisers are the
// thesis's values) and the technique's own.
struct AapsParams : aaps::FeedbackParams {
  uint32_t density_resolution;
  float footprint_scale, max_anisotropy, cull_solid_angle, depth_margin;
  Msaa msaa;
  float msaa_threshold;
  uint32_t msaa_samples;
  FeedbackHalves feedback_halves;
  bool emission_jitter;
  uint32_t max_bounces;
  Indirect indirect;
  uint32_t camera_bounces;
  uint32_t shadow_map_size;
};

// A feedback field as a field of AapsParams (a row binds the struct it reads into).
template <class F>
constexpr F AapsParams::*feedback(F aaps::FeedbackParams::*field) {
  return pb::base_field<AapsParams>(field);
}

// clang-format off
constexpr auto kParams = pb::params(
    pb::param("density_resolution", &AapsParams::density_resolution, 256, {2, 4096}, "texels",
              "side of each light's ray-density texture, a power of two (seed 004 §3.2.2: 256)"),
    pb::param("density_min", feedback(&aaps::FeedbackParams::density_min), 4, {1, 1e6},
              "photons", "density floor, so no texel stops being sampled (§3.2.2: 4)"),
    pb::param("density_max", feedback(&aaps::FeedbackParams::density_max), 0, {0, 1e9},
              "photons", "density ceiling, 0 for none (§3.2.2: none for the thesis's data)"),
    pb::param("target_area", feedback(&aaps::FeedbackParams::target_area), 19, {0.01, 1e6},
              "px^2", "target projected splat area A_t (§4.5.2: 19 gave Pool's best RMSE)"),
    pb::param("variance_gain", feedback(&aaps::FeedbackParams::variance_gain), 2, {0, 1e6},
              "photons",
              "g of D' = D A / A_t + v g, v the energy-weighted relative temporal difference in "
              "[0, 1] (unspecified; 2: half the density floor where a caustic flickers fully)"),
    pb::param("temporal_weight", feedback(&aaps::FeedbackParams::temporal_weight), 0.5,
              {0.01, 1}, "",
              "w_t, the share of the new suggestion D' per frame (unspecified; 0.5)"),
    pb::param("neighbour_weight", feedback(&aaps::FeedbackParams::neighbour_weight), 0.5,
              {0, 100}, "",
              "weight of each 4-neighbour's previous density against 1 for the texel's own "
              "(unspecified)"),
    pb::param("footprint_scale", &AapsParams::footprint_scale, 0.71, {0.05, 10}, "spacings",
              "ellipse semi-axes in photon spacings along the two differentials (unspecified; "
              "0.71 ~ 1/sqrt 2: the ellipse through a spacing cell's corners, so neighbours leave "
              "no holes)"),
    pb::param("max_anisotropy", &AapsParams::max_anisotropy, 16, {1, 1e6}, "",
              "largest ratio of the ellipse's principal semi-axes; above it the minor axis grows "
              "(§3.1.2; unspecified)"),
    pb::param("cull_solid_angle", &AapsParams::cull_solid_angle, 0, {0, 1e6}, "sr",
              "cull splats whose ellipse, sized for the thesis's base sampling (1/512 of the "
              "emission parameter), subtends more than this from the light (§3.3.5; 0: no "
              "culling, the thesis's setting unless stated)"),
    pb::param("depth_margin", &AapsParams::depth_margin, 0.01, {0, 1}, "",
              "relative depth tolerance of a splat against the G-buffer (§3.3.4: 1%)"),
    pb::param("msaa", &AapsParams::msaa, Msaa::none, "none|all|all_per_sample|small_per_sample",
              "splat anti-aliasing (§5.1): none; all splats multisampled, coverage only; all at "
              "sample rate; only splats below msaa_threshold at sample rate"),
    pb::param("msaa_threshold", &AapsParams::msaa_threshold, 2, {0, 1e6}, "px^2",
              "small_per_sample: projected ellipse area below which a splat is drawn at sample "
              "rate (§5.1.3; swept, unspecified)"),
    pb::param("msaa_samples", &AapsParams::msaa_samples, 8, {2, 64}, "samples",
              "samples per pixel of the multisampled buffer, lowered to the device's highest "
              "(§5.1: 8)"),
    pb::param("feedback_halves", &AapsParams::feedback_halves, FeedbackHalves::both,
              "both|refracted",
              "which halves of a split photon give its texel's projected area A (§1.10b): both, "
              "energy-weighted (A = sum f_p a_p), or the refracted ones alone, so that the dim "
              "reflected halves' large splats do not set the density of the focused refracted "
              "ones"),
    pb::param("emission_jitter", &AapsParams::emission_jitter, true,
              "each photon at a fixed pseudo-random point of its grid cell, not the centre (§1.4: "
              "the thesis does not say; at cell centres the lattice of a focus's tiny splats "
              "aliases with the pixel grid)"),
    pb::bind(pb::toolkit::with_range(pb::toolkit::kMaxBouncesParam, 8, 1, 31,
                                     "recursion cap: surface interactions per photon (§1.5, Fig. "
                                     "2; unspecified); photons are stored at the first diffuse "
                                     "hit"),
             &AapsParams::max_bounces),
    pb::param("indirect", &AapsParams::indirect, Indirect::none, "none|splat_bvh",
              "caustics seen through mirrors and glass (indirect_caustics, §5.2): none, the "
              "thesis's AAPS; splat_bvh, every splat's quad (those outside the frustum kept) in a "
              "box BVH rebuilt each frame, walked by each camera path's last segment behind S "
              "vertices with the ellipse test as the any-hit"),
    pb::param("camera_bounces", &AapsParams::camera_bounces, 6, {1, 255}, "hits",
              "splat_bvh: surface hits a camera path may have, its diffuse end included "
              "(unspecified in §5.2; 6, seed 002 Paper V's)"),
    pb::bind(pb::toolkit::kShadowMapSizeParam, &AapsParams::shadow_map_size));
// clang-format on
// The feedback struct keeps its initialisers (the unit tests build it whole): they must be the
// declaration's defaults.
static_assert(static_cast<const aaps::FeedbackParams&>(kParams.defaults()) ==
              aaps::FeedbackParams{});

// The budget knob (match: in a config): a smaller target splat area makes the density feedback emit
// more photons (§4.5.2), so the cost falls and the error grows as the area grows.
const pb_budget_knob kBudget[] = {{"target_area", PB_COST_FALLS, PB_ERROR_GROWS, PB_SCALE_LOG}};

// clang-format off
constexpr auto kCounters = pb::counters({
    {"photons_emitted", PB_COUNTER_WORK, "photons", "photons emitted (the quadtree root)"},
    {"photons_recorded", PB_COUNTER_WORK, "photons", "photons stored at a diffuse hit"},
    {"recorded_share", PB_COUNTER_RATIO, "photons", "photons_recorded / photons_emitted"},
    {"photons_culled", PB_COUNTER_WORK, "photons",
     "recorded but not splatted (culled or outside the frustum)"},
    {"splats_drawn", PB_COUNTER_WORK, "splats", "splats drawn"},
    {"splats_per_sample", PB_COUNTER_WORK, "splats", "splats in the multisampled list"},
    {"splats_noncontributing", PB_COUNTER_WORK, "splats",
     "splats that reached no pixel centre or sample"},
    {"noncontributing_share", PB_COUNTER_RATIO, "splats", "splats_noncontributing / splats_drawn"},
    // A counter named as a parameter is its resolved value (cell.json params_resolved): the
    // samples the device gave (1 without MSAA).
    {"msaa_samples", PB_COUNTER_SIZE, "samples",
     "samples per pixel of the multisampled buffer (1: none)"},
    {"feedback_area_share_reflected", PB_COUNTER_RATIO, "px^2",
     "the reflected halves' share of the projected area the density feedback sees"},
    // Caustic irradiance luminance summed over the screen: the thesis's "total light" (§5.1.1).
    {"caustic_energy", PB_COUNTER_SIZE, "W/m^2 px",
     "caustic irradiance luminance summed over the screen"},
});
// clang-format on
// The splat sizes of the split halves (§3.3.1): accepted splats by projected ellipse area (px^2)
// per half, reflected then refracted, beside the reflected halves' share of the projected area the
// feedback sees (A = sum f_p a_p over a texel's photons, §1.10b) above.
constexpr double kAreaBins[] = {0.25, 1, 4, 16, 64};  // upper edges; the last bin is open
constexpr size_t kAreaBinCount = std::size(kAreaBins) + 1;
// clang-format off
#define AAPS_AREA_BINS(half)                                                                  \
  {"splats_" half "_area_below_0p25", PB_COUNTER_WORK, "splats", "accepted " half " splats"}, \
  {"splats_" half "_area_0p25_1", PB_COUNTER_WORK, "splats", "accepted " half " splats"},     \
  {"splats_" half "_area_1_4", PB_COUNTER_WORK, "splats", "accepted " half " splats"},        \
  {"splats_" half "_area_4_16", PB_COUNTER_WORK, "splats", "accepted " half " splats"},       \
  {"splats_" half "_area_16_64", PB_COUNTER_WORK, "splats", "accepted " half " splats"},      \
  {"splats_" half "_area_above_64", PB_COUNTER_WORK, "splats", "accepted " half " splats"}
// indirect: splat_bvh's (§5.2), counted only with it.
constexpr auto kIndirectCounters = pb::counters({
    {"splats_outside_frustum", PB_COUNTER_WORK, "splats",
     "splats kept for the BVH only: outside the frustum"},
    {"splats_in_bvh", PB_COUNTER_SIZE, "splats", "splats the BVH is built over"},
    {"indirect_walks", PB_COUNTER_WORK, "walks",
     "pixels whose camera path passed S vertices to a diffuse vertex: segment walks"},
    {"segment_box_hits", PB_COUNTER_WORK, "boxes",
     "splat boxes the segments met (any-hit calls)"},
    {"segment_hits", PB_COUNTER_WORK, "splats",
     "splats whose ellipse holds the segment's crossing within the depth margin"},
    {"ellipse_rejections", PB_COUNTER_WORK, "splats",
     "crossings within the depth margin in the quad but outside its ellipse (the quad's other "
     "1 - pi/4)"},
    {"quad_misses", PB_COUNTER_WORK, "splats",
     "crossings within the depth margin outside the quad (its box is larger)"},
    {"bvh_nodes_visited", PB_COUNTER_WORK, "nodes", "BVH nodes the walks popped"},
    {"truncated_walks", PB_COUNTER_WORK, "walks", "walks cut short by the loop budget"},
    {"bvh_nodes", PB_COUNTER_SIZE, "nodes", "nodes of the splat BVH (leaves and inner nodes)"},
    {"bytes_bvh", PB_COUNTER_SIZE, "bytes", "the BVH's buffers, sort and scan scratch"},
    {"bytes_indirect", PB_COUNTER_SIZE, "bytes",
     "splat records, boxes, camera paths and the BVH: GPU memory splat_bvh adds"},
});
constexpr auto kAreaCounters =
    pb::counters({AAPS_AREA_BINS("reflected"), AAPS_AREA_BINS("refracted")});
#undef AAPS_AREA_BINS
// clang-format on
static_assert(kAreaCounters.size() == 2 * kAreaBinCount);

// Every counter above, for the descriptor.
constexpr auto kAllCounters =
    pb::toolkit::join_counters(std::to_array(kCounters.specs), std::to_array(kAreaCounters.specs),
                               std::to_array(kIndirectCounters.specs));

// The emission-parameter spacing the culling rule sizes every splat for (§3.3.5): the thesis's
// base sampling, a 256 x 256 density texture at its floor of 4 photons a texel (2 x 2 each), so
// its thresholds (the lowest tested: 0.0014 sr) mean here what they meant there. The thesis's own
// "perturbation size" is unstated; at one unit of the parameter (the first version's choice)
// every cornell-glass photon subtended more than 0.1 sr, and every threshold it tested culled all.
constexpr float kCullSpacing = 1.f / 512.f;

// One quad corner: world position and quad barycentric u, barycentric v and the splat's
// brightness (irradiance, W/m^2 RGB), the splat's index for the contribution flags.
struct Vertex {
  glm::vec4 position_bary_u;
  glm::vec4 bary_v_brightness;
  uint32_t splat;
};
static_assert(sizeof(Vertex) == 36);
static_assert(sizeof(aaps::SplatRecord) == 64 && offsetof(aaps::SplatRecord, major) == 16 &&
              offsetof(aaps::SplatRecord, minor) == 32 &&
              offsetof(aaps::SplatRecord, brightness) == 48);
static_assert(sizeof(aaps::IndirectPush) == 16);

// What the task-buffer update needs of an accepted photon.
struct Accepted {
  glm::vec3 position;
  uint32_t light, texel;
  float energy_fraction;  // of its texel's share of the light power (§3.1.5)
};

class Aaps final : public pb::Technique {
 public:
  // What the parameters must be together (the descriptor's check: validate reports it before any
  // work); what the device must offer (msaa_samples) is setup's to refuse.
  static std::string check(const pb::Params& params) {
    const AapsParams p = kParams.read(params);
    if (p.density_resolution & (p.density_resolution - 1))
      return fmt::format(
          "density_resolution: {} is not a power of two (the sum quadtree halves it)",
          p.density_resolution);
    if (p.density_max > 0 && p.density_max < p.density_min)
      return fmt::format("density_max: {} is below density_min = {} (0: no ceiling)", p.density_max,
                         p.density_min);
    if (p.indirect == Indirect::none && p.camera_bounces != kParams.defaults().camera_bounces)
      return fmt::format("camera_bounces: {} has no effect with indirect = none", p.camera_bounces);
    return "";
  }

  void setup(pb::Context& ctx, const pb::Params& params) override {
    p_ = kParams.read(params);
    pb::toolkit::configure_direct_light(ctx, params);
    pb::toolkit::configure_shadows(ctx, p_.shadow_map_size);

    // The thesis's photons (photon_rules.h): the task buffer's emission and its caustic rule.
    settings_.max_bounces = p_.max_bounces;
    settings_.seed_per_frame = false;
    settings_.emission = &emission_;
    settings_.policy = &caustic_rule_;
    settings_.footprints = true;  // each splat's ellipse is its photon's footprint (§1.6)
    emission_.set_jitter(p_.emission_jitter);

    pb::gpu::Device& gpu = ctx.gpu();
    width_ = ctx.output().extent().width, height_ = ctx.output().extent().height;
    samples_ = 1;
    if (p_.msaa != Msaa::none) {
      const uint32_t wanted = p_.msaa_samples;
      // The device's highest count up to the one asked for. Below its highest a device need not
      // support every power of two; lavapipe offers 1 and 4 only.
      const uint32_t highest = gpu.limits().max_color_samples;
      while (samples_ * 2 <= std::min(wanted, highest)) samples_ *= 2;
      if (samples_ < highest && gpu.driver().find("llvmpipe") != std::string::npos)
        throw pb::InputError(fmt::format(
            "aaps: msaa_samples {} is not offered by lavapipe (1 or {} samples)", wanted, highest));
      if (samples_ < 2)
        throw pb::InputError(
            fmt::format("aaps: msaa {} needs a multisampled colour target; the "
                        "device offers 1 sample",
                        params.choice("msaa")));
    }
    constexpr vk::Format kFloat4 = vk::Format::eR32G32B32A32Sfloat;
    using Usage = vk::ImageUsageFlagBits;
    vk::Extent2D extent{width_, height_};
    caustics_ = gpu.create_image("aaps.caustics", extent, kFloat4,
                                 Usage::eColorAttachment | Usage::eStorage);
    radiance_ = gpu.create_image("aaps.radiance", extent, kFloat4, Usage::eStorage);
    if (p_.msaa != Msaa::none) {
      caustics_msaa_ = gpu.create_image("aaps.caustics_msaa", extent, kFloat4,
                                        Usage::eColorAttachment | Usage::eSampled,
                                        vk::SampleCountFlagBits(samples_));
    }
    luminance_ =
        gpu.create_buffer("aaps.luminance", uint64_t(width_) * height_ * sizeof(float),
                          vk::BufferUsageFlagBits::eStorageBuffer, pb::gpu::Memory::host_visible);

    auto splat_pipeline = [&](std::string name, std::span<const uint32_t> fragment,
                              vk::SampleCountFlagBits samples, float min_sample_shading) {
      pb::gpu::GraphicsPipelineDesc desc;
      desc.name = std::move(name);
      desc.vertex_spirv = kaaps_splat_vert_spv;
      desc.fragment_spirv = fragment;
      desc.bindings = {Binding::storage_buffer, Binding::storage_image, Binding::storage_image,
                       Binding::storage_buffer};
      desc.push_bytes = sizeof(float);
      desc.vertex_stride = sizeof(Vertex);
      desc.vertex_attributes = {kFloat4, kFloat4, vk::Format::eR32Uint};
      desc.color_formats = {kFloat4};
      desc.samples = samples;
      desc.additive_blend = {true};
      desc.min_sample_shading = min_sample_shading;
      return gpu.create_graphics_pipeline(desc);
    };
    splat_ = splat_pipeline("aaps.splat", kaaps_splat_frag_spv, vk::SampleCountFlagBits::e1, 0);
    if (p_.msaa == Msaa::all)
      splat_msaa_ = splat_pipeline("aaps.splat_msaa", kaaps_splat_frag_spv,
                                   vk::SampleCountFlagBits(samples_), 0);
    else if (p_.msaa != Msaa::none)
      splat_msaa_ = splat_pipeline("aaps.splat_per_sample", kaaps_splat_sample_frag_spv,
                                   vk::SampleCountFlagBits(samples_), 1.f);
    if (p_.msaa == Msaa::none)
      apply_ = gpu.create_compute_pipeline(
          "aaps.apply", kaaps_apply_comp_spv,
          {Binding::storage_image, Binding::storage_image, Binding::storage_image,
           Binding::storage_image, Binding::storage_image, Binding::storage_buffer},
          3 * sizeof(uint32_t));
    else
      apply_ = gpu.create_compute_pipeline(
          "aaps.apply_msaa", kaaps_apply_msaa_comp_spv,
          {Binding::storage_image, Binding::sampled_image, Binding::storage_image,
           Binding::storage_image, Binding::storage_image, Binding::storage_buffer},
          3 * sizeof(uint32_t));

    if (p_.indirect == Indirect::splat_bvh) {
      camera_.max_bounces = p_.camera_bounces;
      bvh_.setup(gpu, "aaps.splat_bvh");
      std::vector<Binding> bindings(4, Binding::storage_buffer);
      bindings.insert(bindings.end(), 3, Binding::storage_image);
      bindings.insert(bindings.end(), 4, Binding::storage_buffer);
      indirect_ = gpu.create_compute_pipeline("aaps.indirect", kaaps_indirect_comp_spv, bindings,
                                              sizeof(aaps::IndirectPush));
      indirect_stats_ = pb::toolkit::storage_buffer(gpu, "aaps.indirect_stats", AAPS_STAT_WORDS * 4,
                                                    pb::gpu::Memory::host_visible);
    }

    pb::trace::PhotonTracer& tracer = ctx.photon_tracer();
    lights_.resize(tracer.light_count());
    for (LightTasks& l : lights_) {
      l.density.width = l.density.height = int(p_.density_resolution);
      l.density.texels.assign(size_t(p_.density_resolution) * p_.density_resolution,
                              p_.density_min);
      l.quadtree.build(l.density.texels, p_.density_resolution);
    }
  }

  void render(pb::Context& ctx) override {
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    const pb::FrameInfo& f = ctx.frame();
    {
      auto scope = ctx.pass("photon-trace");
      std::vector<const pb::trace::EmissionDensity*> counts;
      for (const LightTasks& l : lights_) counts.push_back(&l.density);
      emission_.set_counts(std::move(counts));
      ctx.photon_tracer().trace(settings_, batch_);
      power_per_texel_ = emission_.power_per_texel(batch_.emitted_power);
      build_splats(ctx, f);
    }
    // ctx.cmd() is asked for in each pass: a pass scope may submit and start a fresh buffer.
    const pb::GBuffer g = ctx.shared().gbuffer_images();
    {
      auto scope = ctx.pass("rasterize");
      draw(ctx, caustics_, splat_, vertices_, uint32_t(single_.size()), g);
      if (p_.msaa != Msaa::none)
        draw(ctx, caustics_msaa_, splat_msaa_, vertices_msaa_, uint32_t(multi_.size()), g);
    }
    {
      // With MSAA the multisampled buffer is resolved here, the mean of its samples (§5.1.3's
      // "extra resolve step", folded into the apply dispatch).
      auto scope = ctx.pass("apply");
      vk::CommandBuffer cmd = ctx.cmd();
      uint32_t push[3] = {width_, height_, samples_};
      pb::gpu::Resource multi = p_.msaa != Msaa::none
                                    ? pb::gpu::Resource(pb::gpu::Sampled{&caustics_msaa_})
                                    : pb::gpu::Resource(&caustics_);
      apply_.bind(cmd, {&caustics_, multi, g.position, g.albedo, &radiance_, &luminance_}, push,
                  sizeof(push));
      cmd.dispatch(pb::gpu::groups_for(width_, 8), pb::gpu::groups_for(height_, 8), 1);
      pb::gpu::full_barrier(cmd);
    }
    if (p_.indirect == Indirect::splat_bvh) walk_splats(ctx);
    ctx.shared().shade(&radiance_);
    ctx.flush();
    count(ctx);
    count_indirect(ctx);
    {
      auto scope = ctx.pass("task-update");
      update_tasks(ctx, f);
    }
  }

 private:
  struct LightTasks {
    pb::trace::EmissionDensity density;
    aaps::SumQuadtree quadtree;  // of `density` as the last trace emitted it
    std::vector<float> area, variance;
  };

  // Footprint, acceptance and culling (§1.6-1.7) of every stored photon; the accepted ones become
  // quads in the single-sample or the multisampled list.
  void build_splats(pb::Context& ctx, const pb::FrameInfo& f) {
    single_.clear(), multi_.clear(), accepted_.clear();
    bvh_splats_.clear(), bvh_boxes_.clear();
    outside_frustum_ = 0;
    const bool keep_for_bvh = p_.indirect == Indirect::splat_bvh;
    for (LightTasks& l : lights_) {
      l.area.assign(size_t(p_.density_resolution) * p_.density_resolution, 0.f);
      l.variance.assign(size_t(p_.density_resolution) * p_.density_resolution, 0.f);
    }
    culled_ = 0;
    for (auto& h : area_histogram_) std::fill(std::begin(h), std::end(h), 0);
    weighted_area_[0] = weighted_area_[1] = 0;
    const glm::mat4& vp = f.camera.view_projection;
    auto to_screen = [&](const glm::vec3& p, glm::vec2& s) {
      glm::vec4 c = vp * glm::vec4(p, 1.f);
      if (c.w <= 0) return false;
      s = glm::vec2((c.x / c.w * 0.5f + 0.5f) * float(width_),
                    (c.y / c.w * 0.5f + 0.5f) * float(height_));
      return true;
    };
    for (uint32_t i = 0; i < batch_.photons.size(); ++i) {
      const pb::trace::PhotonRecord& p = batch_.photons[i];
      LightTasks& light = lights_[p.light];
      aaps::SumQuadtree::Leaf leaf = light.quadtree.walk(p.path);
      glm::vec3 major, minor;
      aaps::principal_axes(p.footprint_u * p_.footprint_scale, p.footprint_v * p_.footprint_scale,
                           p_.max_anisotropy, major, minor);
      float world_area = float(M_PI) * glm::length(major) * glm::length(minor);
      glm::vec2 c, s1, s2;
      bool visible = to_screen(p.position, c) && to_screen(p.position + major, s1) &&
                     to_screen(p.position + minor, s2);
      glm::vec2 extent = visible ? glm::abs(s1 - c) + glm::abs(s2 - c) : glm::vec2(0.f);
      bool in_frustum = visible && c.x + extent.x >= 0 && c.x - extent.x <= float(width_) &&
                        c.y + extent.y >= 0 && c.y - extent.y <= float(height_);
      // §3.3.5: the ellipse's solid angle seen from the light, "calculated before scaling the
      // photon's size based on the density texture resolution and sample count": sized for one
      // fixed spacing of the emission parameter, whatever this photon's texel holds.
      bool too_big = false;
      if (p_.cull_solid_angle > 0) {
        float spacing = 1.f / (float(p_.density_resolution) * float(std::max(1u, leaf.m)));
        float scale = kCullSpacing / spacing;
        float d2 = light_distance_squared(ctx, p);
        too_big = world_area * scale * scale / std::max(d2, 1e-12f) > p_.cull_solid_angle;
      }
      if (!in_frustum || too_big || !(world_area > 0)) {
        ++culled_;
        // §5.2: a caustic seen in a mirror or through glass may lie outside the frustum; the
        // BVH keeps it (the density feedback stays the raster's: it sees drawn splats only).
        if (keep_for_bvh && !in_frustum && !too_big && world_area > 0) {
          add_bvh_splat(p.position, major, minor, p.power / world_area);
          ++outside_frustum_;
        }
        continue;
      }
      glm::vec2 d1 = s1 - c, d2 = s2 - c;
      float screen_area = float(M_PI) * std::abs(d1.x * d2.y - d1.y * d2.x);
      glm::vec3 brightness = p.power / world_area;  // §3.2.1: energy / splat area
      if (keep_for_bvh) add_bvh_splat(p.position, major, minor, brightness);
      // The texel's own emitted power (the tracer's): a spot light's texels differ by its falloff.
      float fraction = aaps::energy_fraction(p.power, power_per_texel_[p.light][leaf.texel]);
      const int half = (p.flags & aaps::kRefractedHalf) ? 1 : 0;
      if (p_.feedback_halves == FeedbackHalves::both || half == 1)
        light.area[leaf.texel] += fraction * screen_area;
      size_t bin = 0;
      while (bin < std::size(kAreaBins) && screen_area >= float(kAreaBins[bin])) ++bin;
      ++area_histogram_[half][bin];
      weighted_area_[half] += double(fraction) * screen_area;
      accepted_.push_back({p.position, p.light, leaf.texel, fraction});
      bool per_sample = p_.msaa == Msaa::all || p_.msaa == Msaa::all_per_sample ||
                        (p_.msaa == Msaa::small_per_sample && screen_area < p_.msaa_threshold);
      std::vector<Vertex>& list = per_sample ? multi_ : single_;
      uint32_t splat = uint32_t(accepted_.size() - 1);
      const glm::vec2 corner[6] = {{-1, -1}, {1, -1}, {1, 1}, {-1, -1}, {1, 1}, {-1, 1}};
      for (const glm::vec2& q : corner) {
        glm::vec3 position = p.position + q.x * major + q.y * minor;
        list.push_back({glm::vec4(position, q.x), glm::vec4(q.y, brightness), splat});
      }
    }
    splats_per_sample_ = uint32_t(multi_.size() / 6);
    upload(ctx, single_, vertices_, "aaps.vertices");
    upload(ctx, multi_, vertices_msaa_, "aaps.vertices_msaa");
    uint64_t flag_bytes = std::max<uint64_t>(4, accepted_.size() * sizeof(uint32_t));
    if (contributed_.size() < flag_bytes)
      contributed_ = ctx.gpu().create_buffer("aaps.contributed", flag_bytes * 2,
                                             vk::BufferUsageFlagBits::eStorageBuffer,
                                             pb::gpu::Memory::host_visible);
    std::memset(contributed_.mapped(), 0, flag_bytes);
    if (keep_for_bvh) upload_bvh_splats(ctx);
  }

  // A splat for the BVH (indirect: splat_bvh): its record and the box around its quad.
  void add_bvh_splat(const glm::vec3& centre, const glm::vec3& major, const glm::vec3& minor,
                     const glm::vec3& brightness) {
    aaps::SplatRecord r{};
    r.centre = centre, r.major = major, r.minor = minor, r.brightness = brightness;
    bvh_splats_.push_back(r);
    const glm::vec3 half = glm::abs(major) + glm::abs(minor);
    pb::toolkit::BvhBox box{};
    box.lo = centre - half, box.hi = centre + half;
    bvh_boxes_.push_back(box);
  }

  // The splat records and boxes into their buffers, grown (with the BVH's) before any of the
  // frame's GPU work that uses them is recorded.
  void upload_bvh_splats(pb::Context& ctx) {
    const uint32_t n = uint32_t(bvh_splats_.size());
    if (n > bvh_capacity_ || !splat_records_) {
      bvh_capacity_ = std::max<uint32_t>(1024, n + n / 4);
      pb::gpu::Device& gpu = ctx.gpu();
      pb::toolkit::check_storage_range(gpu, uint64_t(bvh_capacity_) * sizeof(aaps::SplatRecord),
                                       fmt::format("aaps: {} splats in the BVH", n));
      splat_records_ = pb::toolkit::storage_buffer(
          gpu, "aaps.splat_records", uint64_t(bvh_capacity_) * sizeof(aaps::SplatRecord),
          pb::gpu::Memory::host_visible);
      splat_boxes_ = pb::toolkit::storage_buffer(
          gpu, "aaps.splat_boxes", uint64_t(bvh_capacity_) * sizeof(pb::toolkit::BvhBox),
          pb::gpu::Memory::host_visible);
      bvh_.reserve(bvh_capacity_);
    }
    std::memcpy(splat_records_.mapped(), bvh_splats_.data(), n * sizeof(aaps::SplatRecord));
    std::memcpy(splat_boxes_.mapped(), bvh_boxes_.data(), n * sizeof(pb::toolkit::BvhBox));
  }

  // §5.2: camera paths, the BVH over the splats' quads rebuilt, and per pixel behind S vertices
  // the segment walk (aaps_indirect.comp), after apply (it adds to the radiance apply wrote).
  void walk_splats(pb::Context& ctx) {
    pb::trace_and_upload_camera_paths(ctx, camera_, paths_, paths_buffer_, "aaps.camera_paths");
    const pb::gpu::Image& indirect_image = ctx.class_output("indirect_caustics");
    const pb::gpu::Image& caustics_image = ctx.class_output("caustics");
    {
      auto scope = ctx.pass("splat-bvh");
      vk::CommandBuffer cmd = ctx.cmd();
      cmd.fillBuffer(indirect_stats_.handle(), 0, VK_WHOLE_SIZE, 0u);
      pb::gpu::full_barrier(cmd);
      bvh_.record_build(cmd, splat_boxes_, uint32_t(bvh_splats_.size()));
    }
    {
      auto scope = ctx.pass("indirect");
      vk::CommandBuffer cmd = ctx.cmd();
      const aaps::IndirectPush push{width_, height_, PB_LOOP_BUDGET, p_.depth_margin};
      const auto walk = bvh_.walk_resources(splat_boxes_);
      const pb::gpu::Resource resources[] = {
          &paths_buffer_,   &splat_records_, &ctx.shared().material_buffer(),
          &indirect_stats_, &radiance_,      &caustics_image,
          &indirect_image,  walk[0],         walk[1],
          walk[2],          walk[3]};
      indirect_.bind(cmd, std::span<const pb::gpu::Resource>(resources), push);
      cmd.dispatch(pb::gpu::groups_for(width_, 8), pb::gpu::groups_for(height_, 8), 1);
      pb::gpu::full_barrier(cmd);
    }
  }

  // Every frame, zeros too (indirect: none).
  void count_indirect(pb::Context& ctx) {
    if (p_.indirect == Indirect::none) {
      for (const pb_counter_spec& c : kIndirectCounters.specs) pb::count(ctx, c, 0.0);
      return;
    }
    const auto* s = static_cast<const uint32_t*>(indirect_stats_.mapped());
    auto wide = [&](uint32_t at) { return double(s[at]) + double(s[at + 1]) * 4294967296.0; };
    const pb::toolkit::BoxBvh::Stats bvh = bvh_.read_stats();
    const double bytes = double(splat_records_.size() + splat_boxes_.size() + paths_buffer_.size() +
                                indirect_stats_.size() + bvh_.bytes());
    pb::count(ctx, kIndirectCounters["splats_outside_frustum"], double(outside_frustum_));
    pb::count(ctx, kIndirectCounters["splats_in_bvh"], double(bvh_splats_.size()));
    pb::count(ctx, kIndirectCounters["indirect_walks"], wide(AAPS_STAT_WALKS));
    pb::count(ctx, kIndirectCounters["segment_box_hits"], wide(AAPS_STAT_BOX_HITS));
    pb::count(ctx, kIndirectCounters["segment_hits"], wide(AAPS_STAT_SEGMENT_HITS));
    pb::count(ctx, kIndirectCounters["ellipse_rejections"], wide(AAPS_STAT_ELLIPSE_REJECTED));
    pb::count(ctx, kIndirectCounters["quad_misses"], wide(AAPS_STAT_QUAD_MISSES));
    pb::count(ctx, kIndirectCounters["bvh_nodes_visited"], wide(AAPS_STAT_NODES));
    pb::count(ctx, kIndirectCounters["truncated_walks"], s[AAPS_STAT_TRUNCATED]);
    pb::count(ctx, kIndirectCounters["bvh_nodes"], bvh.nodes());
    pb::count(ctx, kIndirectCounters["bytes_bvh"], double(bvh_.bytes()));
    pb::count(ctx, kIndirectCounters["bytes_indirect"], bytes);
    if (s[AAPS_STAT_TRUNCATED] > 0)
      ctx.warn(fmt::format("aaps: {} splat BVH walks cut short by the loop budget",
                           s[AAPS_STAT_TRUNCATED]));
    if (bvh.long_runs > 0)
      ctx.warn(
          fmt::format("aaps: {} Morton runs of splats longer than the loop budget", bvh.long_runs));
  }

  // §3.3.5's distance: from the light's position (point and spot lights, the shared passes'
  // light buffer, updated each frame); a directional light has none, so its rule is one of area.
  float light_distance_squared(pb::Context& ctx, const pb::trace::PhotonRecord& p) const {
    auto lights = ctx.shared().light_buffer().view<pb::layout::GpuLight>();
    if (p.light >= lights.size() || int(lights[p.light].position_type.w) == PB_LIGHT_DIRECTIONAL)
      return 1.f;
    glm::vec3 d = p.position - glm::vec3(lights[p.light].position_type);
    return glm::dot(d, d);
  }

  void upload(pb::Context& ctx, const std::vector<Vertex>& list, pb::gpu::Buffer& buffer,
              const char* name) {
    uint64_t bytes = std::max<uint64_t>(sizeof(Vertex), list.size() * sizeof(Vertex));
    if (buffer.size() < bytes)
      buffer = ctx.gpu().create_buffer(name, bytes * 3 / 2, vk::BufferUsageFlagBits::eVertexBuffer,
                                       pb::gpu::Memory::host_visible);
    if (!list.empty()) std::memcpy(buffer.mapped(), list.data(), list.size() * sizeof(Vertex));
  }

  void draw(pb::Context& ctx, const pb::gpu::Image& target, const pb::gpu::Pipeline& pipeline,
            const pb::gpu::Buffer& vertices, uint32_t vertex_count, const pb::GBuffer& g) {
    vk::CommandBuffer cmd = ctx.cmd();
    vk::RenderingAttachmentInfo color{target.view(),
                                      vk::ImageLayout::eGeneral,
                                      {},
                                      {},
                                      {},
                                      vk::AttachmentLoadOp::eClear,
                                      vk::AttachmentStoreOp::eStore,
                                      vk::ClearColorValue(std::array<float, 4>{0, 0, 0, 0})};
    vk::Rect2D area{{0, 0}, {width_, height_}};
    ctx.gpu().begin_rendering(cmd, vk::RenderingInfo{{}, area, 1, 0, color});
    if (vertex_count > 0) {
      cmd.setViewport(0, vk::Viewport{0, 0, float(width_), float(height_), 0, 1});
      cmd.setScissor(0, area);
      pipeline.bind(cmd, {&ctx.shared().frame_buffer(), g.position, g.normal, &contributed_},
                    p_.depth_margin);
      cmd.bindVertexBuffers(0, vertices.handle(), vk::DeviceSize(0));
      cmd.draw(vertex_count, 1, 0, 0);
    }
    ctx.gpu().end_rendering(cmd);
    pb::gpu::full_barrier(cmd);
  }

  void count(pb::Context& ctx) {
    uint64_t emitted = batch_.stats.paths, recorded = batch_.photons.size();
    const uint32_t* flags = static_cast<const uint32_t*>(contributed_.mapped());
    uint64_t silent = 0;
    for (size_t i = 0; i < accepted_.size(); ++i) silent += flags[i] == 0 ? 1 : 0;
    pb::count(ctx, kCounters["photons_emitted"], double(emitted));
    pb::count(ctx, kCounters["photons_recorded"], double(recorded));
    pb::count(ctx, kCounters["recorded_share"],
              emitted > 0 ? double(recorded) / double(emitted) : 0.0);
    pb::count(ctx, kCounters["photons_culled"], double(culled_));
    pb::count(ctx, kCounters["splats_drawn"], double(accepted_.size()));
    pb::count(ctx, kCounters["splats_per_sample"], double(splats_per_sample_));
    pb::count(ctx, kCounters["splats_noncontributing"], double(silent));
    pb::count(ctx, kCounters["noncontributing_share"],
              accepted_.empty() ? 0.0 : double(silent) / double(accepted_.size()));
    pb::count(ctx, kCounters["msaa_samples"], double(samples_));
    for (int half = 0; half < 2; ++half)
      for (size_t bin = 0; bin < kAreaBinCount; ++bin)
        pb::count(ctx, kAreaCounters.specs[half * kAreaBinCount + bin],
                  double(area_histogram_[half][bin]));
    const double weighted = weighted_area_[0] + weighted_area_[1];
    pb::count(ctx, kCounters["feedback_area_share_reflected"],
              weighted > 0 ? weighted_area_[0] / weighted : 0.0);
    const float* luminance = static_cast<const float*>(luminance_.mapped());
    double energy = 0;
    for (size_t i = 0; i < size_t(width_) * height_; ++i) energy += luminance[i];
    pb::count(ctx, kCounters["caustic_energy"], energy);
  }

  // §1.10: variance by reprojection against the previous frame's caustics, the density update and
  // the quadtree of the next frame's emission.
  void update_tasks(pb::Context& ctx, const pb::FrameInfo& f) {
    const float* now = static_cast<const float*>(luminance_.mapped());
    {
      auto scope = ctx.pass("variance");
      std::vector<std::vector<aaps::VarianceInput>> per_light(lights_.size());
      for (const Accepted& a : accepted_)
        per_light[a.light].push_back({a.position, a.texel, a.energy_fraction});
      for (uint32_t l = 0; l < lights_.size(); ++l)
        aaps::accumulate_variance(per_light[l], now, f.camera.view_projection, previous_luminance_,
                                  previous_view_projection_, width_, height_, lights_[l].variance);
      previous_luminance_.assign(now, now + size_t(width_) * height_);
      previous_view_projection_ = f.camera.view_projection;
    }
    {
      auto scope = ctx.pass("density");
      for (LightTasks& l : lights_)
        aaps::update_density(l.density.texels, l.area, l.variance, p_.density_resolution, p_);
    }
    {
      auto scope = ctx.pass("quadtree");
      for (LightTasks& l : lights_) l.quadtree.build(l.density.texels, p_.density_resolution);
    }
  }

  AapsParams p_ = kParams.defaults();
  uint32_t width_ = 0, height_ = 0, samples_ = 1;
  pb::trace::TraceSettings settings_;
  aaps::GridEmission emission_;
  aaps::CausticSplitRule caustic_rule_;
  pb::trace::PhotonBatch batch_;
  std::vector<std::vector<float>> power_per_texel_;  // per light and texel: its photons' power
  std::vector<LightTasks> lights_;
  std::vector<Vertex> single_, multi_;
  std::vector<Accepted> accepted_;
  uint64_t culled_ = 0;
  uint64_t area_histogram_[2][kAreaBinCount] = {};  // [reflected, refracted][bin]
  double weighted_area_[2] = {};                    // sum of f_p a_p per half
  uint32_t splats_per_sample_ = 0;
  std::vector<float> previous_luminance_;
  glm::mat4 previous_view_projection_{1.f};
  pb::gpu::Image caustics_, caustics_msaa_, radiance_;
  pb::gpu::Buffer luminance_, vertices_, vertices_msaa_, contributed_;
  pb::gpu::Pipeline splat_, splat_msaa_, apply_;
  // indirect: splat_bvh
  std::vector<aaps::SplatRecord> bvh_splats_;
  std::vector<pb::toolkit::BvhBox> bvh_boxes_;
  uint64_t outside_frustum_ = 0;
  uint32_t bvh_capacity_ = 0;
  pb::toolkit::BoxBvh bvh_;
  pb::trace::CameraPathSettings camera_;
  pb::trace::CameraPathBatch paths_;
  pb::gpu::Buffer splat_records_, splat_boxes_, paths_buffer_, indirect_stats_;
  pb::gpu::Pipeline indirect_;
};

}  // namespace

// The shared direct light's rows (the toolkit's: shadow maps or many-light next-event estimation,
// seed 002 Papers III and IV) after the technique's own.
constexpr auto kSchema = pb::join_rows(kParams, pb::toolkit::kDirectLightParams);

PB_EXPORT_TECHNIQUE(Aaps, "aaps", "caustics",
                    "adaptive anisotropic photon scattering (seed 004): task-buffer emission, "
                    "elliptical splats rasterised with optional (per-sample) MSAA",
                    kSchema.rows, .counters = kAllCounters, .check = &Aaps::check,
                    .budget = kBudget)
