// collection-points: Moreau et al., "Real-Time Rendering of Indirectly Visible Caustics" (GRAPP
// 2022; seed 002, Paper V). Caustics seen in a mirror or through glass (C S+ D S+ L) are gathered
// where the camera path meets its first diffuse vertex, not on the first hit the G-buffer sees.
// Per frame:
//   camera-paths       the API's camera paths through S vertices to the first D vertex (CPU);
//   collection-points  a CP at each path's D vertex, its radius the ray cone's footprint capped
//                      at radius_cap, the box of its flat cylinder (height r / 10) (§3);
//   photon-trace       caustic light paths L S+ D (the shared tracer), photon-upload their hits
//                      with the material each landed on;
//   cp-bvh             the toolkit's box BVH over the CP boxes, rebuilt every frame (§3.2: the
//                      paper's DXR build) or, cp_update: refit, the first build's tree refitted
//                      over one box slot per pixel (the paper's refit, its tracing 10x slower);
//   reuse              temporal only: last frame's CPs gathered at each CP (§3.1, Eqs. 3-4);
//   accumulate         per photon a point walk; every CP whose cylinder holds the hit, of its
//                      material, sums the flux in fixed point (§3.2);
//   resolve            L = tau f I / (pi r^2) (Eq. 1), the EMA with alpha (Eq. 2), into the
//                      class image (indirect_caustics) and the combined estimate.
// README.md gives the parameters, counters, deviations and measured figures. When it fails: few
// caustic photons per CP (the paper's 1024^2 paths scaled to the frame's pixels) give a noisy
// estimate; overlapping CPs (an area seen directly and in a mirror) make photon walks longer.
#include "photonbench/toolkit/technique.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "collection-points_shaders.h"
#include "collection_points.h"
#include "photonbench/param_table.h"
#include "photonbench/plugin.h"
#include "photonbench/toolkit/box_bvh.h"
#include "photonbench/toolkit/fixed_point.h"

namespace {

namespace tk = pb::toolkit;
using pb::gpu::Binding;

enum class Accumulator : uint32_t { fixed64, fixed4_28 };
enum class CpUpdate : uint32_t { rebuild, refit };
enum class Emission : uint32_t { aimed, power };

struct CpParams {
  uint32_t light_paths = 1048576;
  uint32_t max_bounces = 6;
  uint32_t camera_bounces = 6;
  float radius_cap = 0.005f;
  Accumulator accumulator = Accumulator::fixed64;
  CpUpdate cp_update = CpUpdate::rebuild;
  Emission emission = Emission::aimed;
  bool temporal = false;
  float temporal_alpha = 0.8f;
  uint32_t shadow_map_size = pb::kDefaultShadowMapSize;
};

constexpr double kPaperPixels = 1920.0 * 1080.0;

// clang-format off
constexpr auto kParams = pb::params(
    pb::param("light_paths", &CpParams::light_paths, 1048576, {1, 1e9}, "paths",
              "light paths per frame at 1920 x 1080 (Paper V §4: 1024^2), scaled by the frame's "
              "pixels / (1920 x 1080), as CPs are one per pixel"),
    pb::bind(tk::with_range(tk::kMaxBouncesParam, 6, 2, 31,
                            "surface interactions per light path; caustic photons (L S+ D) are "
                            "stored at their first diffuse hit (Paper V §4: path length 6)"),
             &CpParams::max_bounces),
    pb::param("camera_bounces", &CpParams::camera_bounces, 6, {1, 255}, "hits",
              "surface hits a camera path may have, its diffuse end included (Paper V: 6)"),
    pb::param("radius_cap", &CpParams::radius_cap, 0.005, {1e-6, 10}, "m",
              "the CP radius cap at 1920 pixels wide (Paper V §3: 5 mm), scaled by 1920 / width "
              "so that it spans the same pixels at every resolution"),
    pb::param("accumulator", &CpParams::accumulator, Accumulator::fixed64, "fixed64|fixed4_28",
              "fixed64: the toolkit's 64-bit fixed-point sums; fixed4_28: Paper V §3.2's 32-bit "
              "format, 4 integer and 28 fractional bits, each add clamped at 15 (counted)"),
    pb::param("cp_update", &CpParams::cp_update, CpUpdate::rebuild, "rebuild|refit",
              "rebuild: a new CP BVH every frame (Paper V §3.2); refit: one box slot per pixel, "
              "the first frame's tree kept and its boxes joined anew bottom-up, the paper's "
              "refit, which it found an order of magnitude slower to trace"),
    pb::param("emission", &CpParams::emission, Emission::aimed, "aimed|power",
              "aimed: each light emits only towards the frame's specular objects, the tracer's "
              "aimed-emission policy in place of Paper V §4's projection volume (Kim 2019), valid "
              "because only caustic photons (L S+ D) are kept; power: from the lights by power "
              "over their whole emission domain"),
    pb::param("temporal", &CpParams::temporal, false,
              "reuse last frame's CPs (Paper V §3.1): a Gaussian gather (sigma 3/4 r, "
              "|dp| <= r, n . n' >= 0.9, same material), then an exponential average"),
    pb::param("temporal_alpha", &CpParams::temporal_alpha, 0.8, {0, 1}, "",
              "alpha of Eq. 2, the reused value's weight (Paper V: 0.8)"),
    pb::bind(tk::kShadowMapSizeParam, &CpParams::shadow_map_size));
// clang-format on
static_assert(kParams.member_defaults_match());

constexpr auto kCounters = pb::counters({
    {"collection_points", PB_COUNTER_SIZE, "CPs",
     "CPs this frame (pixels whose camera path "
     "ended on a diffuse vertex)"},
    {"collection_points_behind_specular", PB_COUNTER_SIZE, "CPs",
     "CPs with at least one S vertex before them (the indirect_caustics class's)"},
    {"radii_capped", PB_COUNTER_SIZE, "CPs", "CP radii cut to the cap"},
    {"radius_mean", PB_COUNTER_SIZE, "m", "mean CP radius"},
    tk::kPhotonsStoredCounter,
    {"cp_boxes_tested", PB_COUNTER_WORK, "boxes", "CP boxes the photons' point walks tested"},
    {"cp_boxes_tested_per_photon", PB_COUNTER_RATIO, "boxes", "cp_boxes_tested / photons_stored"},
    {"bvh_nodes_visited", PB_COUNTER_WORK, "nodes", "BVH nodes the photons' walks popped"},
    {"contributions", PB_COUNTER_WORK, "pairs", "photon-CP pairs accumulated"},
    {"saturated_sums", PB_COUNTER_WORK, "adds",
     "fixed4_28: channel adds clamped at 15 or wrapping the 32-bit word"},
    {"truncated_walks", PB_COUNTER_WORK, "walks", "walks cut short by the loop budget"},
    {"reused_collection_points", PB_COUNTER_WORK, "CPs",
     "temporal: CPs that took last frame's contributions"},
    {"reuse_boxes_tested", PB_COUNTER_WORK, "boxes", "temporal: last frame's CP boxes tested"},
    {"bvh_nodes", PB_COUNTER_SIZE, "nodes", "nodes of the CP BVH (leaves and inner nodes)"},
    {"bvh_leaves", PB_COUNTER_SIZE, "nodes", "leaves: runs of equal Morton codes"},
    {"bytes_bvh", PB_COUNTER_SIZE, "bytes", "the BVH's buffers, sort and scan scratch"},
    {"bytes_total", PB_COUNTER_SIZE, "bytes", "GPU memory of the technique's buffers"},
});

constexpr uint32_t kAccumulatorBytes = CP_ACCUM_WORDS * 4;

class CollectionPoints final : public pb::Technique {
 public:
  static std::string check(const pb::Params& params) {
    const CpParams p = kParams.read(params);
    if (!p.temporal && p.temporal_alpha != kParams.defaults().temporal_alpha)
      return fmt::format("temporal_alpha: {} has no effect with temporal = false",
                         p.temporal_alpha);
    return "";
  }

  void setup(pb::Context& ctx, const pb::Params& params) override {
    p_ = kParams.read(params);
    pb::toolkit::configure_direct_light(ctx, params);
    tk::configure_shadows(ctx, p_.shadow_map_size);
    pb::gpu::Device& gpu = ctx.gpu();
    width_ = ctx.output().extent().width;
    height_ = ctx.output().extent().height;
    camera_.max_bounces = p_.camera_bounces;
    trace_.paths = std::max<uint32_t>(
        1, uint32_t(std::lround(double(p_.light_paths) * width_ * height_ / kPaperPixels)));
    trace_.max_bounces = p_.max_bounces;
    trace_.store = pb::trace::kCausticPhotons;
    cap_ = cp::radius_cap(p_.radius_cap, width_);
    std::vector<Binding> bindings(9, Binding::storage_buffer);
    bindings.push_back(Binding::storage_image);
    bindings.insert(bindings.end(), 4, Binding::storage_buffer);
    bindings.push_back(Binding::storage_image);
    auto make = [&](const char* name, std::span<const uint32_t> spirv) {
      return gpu.create_compute_pipeline(std::string("collection-points/") + name, spirv, bindings,
                                         sizeof(cp::CpPush));
    };
    reuse_ = make("reuse", kcp_reuse_comp_spv);
    accumulate_ = make("accumulate", kcp_accumulate_comp_spv);
    resolve_ = make("resolve", kcp_resolve_comp_spv);
    combined_ = gpu.create_image("collection-points/combined", {width_, height_},
                                 vk::Format::eR32G32B32A32Sfloat, vk::ImageUsageFlagBits::eStorage);
    stats_ = tk::storage_buffer(gpu, "collection-points/stats", CP_STAT_WORDS * 4,
                                pb::gpu::Memory::host_visible);
    pixel_map_ = tk::storage_buffer(gpu, "collection-points/point-of-pixel",
                                    uint64_t(width_) * height_ * 4, pb::gpu::Memory::host_visible);
    // Both sets get their buffers now: the first frame's reuse pass binds last frame's (empty).
    for (int s = 0; s < 2; ++s) {
      sets_[s].bvh.setup(gpu, fmt::format("collection-points/bvh{}", s));
      reserve_points(ctx, sets_[s], 0);
    }
  }

  void render(pb::Context& ctx) override {
    Set& cur = sets_[current_];
    Set& prev = sets_[1 - current_];
    {
      auto scope = ctx.pass("camera-paths");
      ctx.camera_paths(camera_, paths_);
    }
    {
      auto scope = ctx.pass("collection-points");
      cp::make_points(paths_.paths, cap_, points_, p_.cp_update == CpUpdate::refit);
      reserve_points(ctx, cur, uint32_t(points_.points.size()));
      std::memcpy(cur.points.mapped(), points_.points.data(),
                  points_.points.size() * sizeof(cp::CpPoint));
      std::memcpy(cur.boxes.mapped(), points_.boxes.data(),
                  points_.boxes.size() * sizeof(tk::BvhBox));
      std::memcpy(pixel_map_.mapped(), points_.point_of_pixel.data(),
                  points_.point_of_pixel.size() * 4);
      cur.count = uint32_t(points_.points.size());
    }
    {
      auto scope = ctx.pass("photon-trace");
      pb::trace::PhotonTracer& tracer = ctx.photon_tracer();
      if (p_.emission == Emission::aimed) {
        // Every frame: the specular objects move. A light that reaches none keeps its uniform
        // emission (no density).
        pb::trace::aim_emission(tracer);
      }
      tracer.trace(trace_, batch_);
    }
    {
      auto scope = ctx.pass("photon-upload");
      cp::make_photons(batch_.photons, ctx.shared().scene_triangles(), photons_host_);
      const uint64_t bytes = std::max<uint64_t>(1, photons_host_.size()) * sizeof(cp::CpPhoton);
      if (!photons_ || photons_.size() < bytes) {
        tk::check_storage_range(ctx.gpu(), bytes,
                                fmt::format("collection-points: {} photons", photons_host_.size()));
        photons_ = tk::storage_buffer(ctx.gpu(), "collection-points/photons", bytes + bytes / 2,
                                      pb::gpu::Memory::host_visible);
      }
      std::memcpy(photons_.mapped(), photons_host_.data(),
                  photons_host_.size() * sizeof(cp::CpPhoton));
    }
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    const pb::gpu::Image& class_image = ctx.class_output("indirect_caustics");

    cp::CpPush push{};
    push.points = cur.count;
    push.photons = uint32_t(photons_host_.size());
    push.width = width_;
    push.height = height_;
    const tk::FluxScale scale = tk::FluxScale::for_photons(batch_.photons);
    push.units_per_watt = scale.units_per_watt;
    push.watts_per_unit = scale.watts_per_unit;
    push.accumulator =
        p_.accumulator == Accumulator::fixed64 ? CP_ACCUMULATOR_FIXED64 : CP_ACCUMULATOR_FIXED4_28;
    push.temporal = p_.temporal ? 1u : 0u;
    push.alpha = p_.temporal_alpha;
    push.sigma_scale = 0.75f;  // Eq. 3
    push.normal_min = 0.9f;    // Eq. 4
    push.budget = PB_LOOP_BUDGET;
    push.prev_points = prev.count;

    auto resources = [&](const Set& walked) {
      const auto walk = walked.bvh.walk_resources(walked.boxes);
      return std::vector<pb::gpu::Resource>{
          &cur.points,    &photons_,     &accum_,
          &stats_,        &pixel_map_,   &prev.points,
          &prev.radiance, &cur.radiance, &ctx.shared().material_buffer(),
          &class_image,   walk[0],       walk[1],
          walk[2],        walk[3],       &combined_};
    };
    vk::CommandBuffer cmd = ctx.cmd();
    cmd.fillBuffer(stats_.handle(), 0, VK_WHOLE_SIZE, 0u);
    cmd.fillBuffer(accum_.handle(), 0, VK_WHOLE_SIZE, 0u);
    pb::gpu::full_barrier(cmd);
    {
      auto scope = ctx.pass("cp-bvh");
      if (p_.cp_update == CpUpdate::refit && cur.bvh.can_refit(cur.count))
        cur.bvh.record_refit(ctx.cmd(), cur.boxes, cur.count);
      else
        cur.bvh.record_build(ctx.cmd(), cur.boxes, cur.count);
    }
    auto dispatch = [&](const pb::gpu::Pipeline& pipeline, const std::vector<pb::gpu::Resource>& r,
                        uint32_t x, uint32_t y) {
      if (x == 0 || y == 0) return;
      vk::CommandBuffer c = ctx.cmd();
      pipeline.bind(c, std::span<const pb::gpu::Resource>(r), push);
      c.dispatch(x, y, 1);
      pb::gpu::full_barrier(c);
    };
    if (p_.temporal) {
      auto scope = ctx.pass("reuse");
      dispatch(reuse_, resources(prev), pb::gpu::groups_for(cur.count, 64), 1);
    }
    const auto own = resources(cur);
    {
      auto scope = ctx.pass("accumulate");
      dispatch(accumulate_, own, pb::gpu::groups_for(push.photons, 64), 1);
    }
    {
      auto scope = ctx.pass("resolve");
      dispatch(resolve_, own, pb::gpu::groups_for(width_, 8), pb::gpu::groups_for(height_, 8));
    }
    ctx.shared().shade(&combined_);
    ctx.flush();
    report(ctx, cur);
    current_ = 1 - current_;
  }

 private:
  // One frame's CPs, their boxes, BVH and blended radiance; two of them, this frame's and last's.
  struct Set {
    pb::gpu::Buffer points, boxes, radiance;
    tk::BoxBvh bvh;
    uint32_t count = 0, capacity = 0;  // count: CPs, or pixel slots with cp_update: refit
  };

  // Room for `count` CPs in `set` and the accumulator (before any of the frame's GPU work is
  // recorded: recorded work would refer to replaced buffers).
  void reserve_points(pb::Context& ctx, Set& set, uint32_t count) {
    pb::gpu::Device& gpu = ctx.gpu();
    if (count > set.capacity || !set.points) {
      set.capacity = std::max<uint32_t>(1024, count + count / 4);
      const uint64_t n = set.capacity;
      const std::string what = fmt::format("collection-points: {} CPs", count);
      tk::check_storage_range(gpu, n * sizeof(cp::CpPoint), what);
      set.points = tk::storage_buffer(gpu, "collection-points/points", n * sizeof(cp::CpPoint),
                                      pb::gpu::Memory::host_visible);
      set.boxes = tk::storage_buffer(gpu, "collection-points/boxes", n * sizeof(tk::BvhBox),
                                     pb::gpu::Memory::host_visible);
      set.radiance = tk::storage_buffer(gpu, "collection-points/radiance", n * 16);
      set.bvh.reserve(set.capacity);
    }
    const uint64_t accum_bytes = uint64_t(std::max<uint32_t>(count, 1)) * kAccumulatorBytes;
    if (!accum_ || accum_.size() < accum_bytes)
      accum_ =
          tk::storage_buffer(gpu, "collection-points/accumulator", accum_bytes + accum_bytes / 4);
  }

  uint64_t bytes_total() const {
    uint64_t b =
        combined_.bytes() + stats_.size() + pixel_map_.size() + photons_.size() + accum_.size();
    for (const Set& s : sets_)
      b += s.points.size() + s.boxes.size() + s.radiance.size() + s.bvh.bytes();
    return b;
  }

  void report(pb::Context& ctx, const Set& cur) {
    const auto* s = static_cast<const uint32_t*>(stats_.mapped());
    auto wide = [&](uint32_t at) { return double(s[at]) + double(s[at + 1]) * 4294967296.0; };
    const tk::BoxBvh::Stats bvh = cur.bvh.read_stats();
    const double photons = double(photons_host_.size());
    pb::count(ctx, kCounters["collection_points"], points_.count);
    pb::count(ctx, kCounters["collection_points_behind_specular"], points_.behind_specular);
    pb::count(ctx, kCounters["radii_capped"], points_.capped);
    pb::count(ctx, kCounters["radius_mean"],
              points_.count > 0 ? points_.radius_sum / points_.count : 0.0);
    pb::count(ctx, tk::kPhotonsStoredCounter, photons);
    pb::count(ctx, kCounters["cp_boxes_tested"], wide(CP_STAT_BOXES_TESTED));
    pb::count(ctx, kCounters["cp_boxes_tested_per_photon"],
              photons > 0 ? wide(CP_STAT_BOXES_TESTED) / photons : 0.0);
    pb::count(ctx, kCounters["bvh_nodes_visited"], wide(CP_STAT_NODES));
    pb::count(ctx, kCounters["contributions"], wide(CP_STAT_CONTRIBUTIONS));
    pb::count(ctx, kCounters["saturated_sums"], s[CP_STAT_SATURATED]);
    pb::count(ctx, kCounters["truncated_walks"], s[CP_STAT_TRUNCATED]);
    pb::count(ctx, kCounters["reused_collection_points"], s[CP_STAT_REUSED]);
    pb::count(ctx, kCounters["reuse_boxes_tested"], wide(CP_STAT_REUSE_TESTED));
    pb::count(ctx, kCounters["bvh_nodes"], bvh.nodes());
    pb::count(ctx, kCounters["bvh_leaves"], bvh.leaves);
    pb::count(ctx, kCounters["bytes_bvh"], double(cur.bvh.bytes()));
    pb::count(ctx, kCounters["bytes_total"], double(bytes_total()));
    if (s[CP_STAT_TRUNCATED] > 0)
      ctx.warn(fmt::format("collection-points: {} BVH walks cut short by the loop budget",
                           s[CP_STAT_TRUNCATED]));
    if (bvh.long_runs > 0)
      ctx.warn(fmt::format("collection-points: {} Morton runs longer than the loop budget",
                           bvh.long_runs));
    if (s[CP_STAT_SATURATED] > 0)
      ctx.warn(fmt::format("collection-points: {} fixed4_28 adds saturated", s[CP_STAT_SATURATED]));
  }

  CpParams p_;
  uint32_t width_ = 0, height_ = 0, current_ = 0;
  float cap_ = 0;
  pb::trace::CameraPathSettings camera_;
  pb::trace::CameraPathBatch paths_;
  pb::trace::TraceSettings trace_;
  pb::trace::PhotonBatch batch_;
  cp::PointSet points_;
  std::vector<cp::CpPhoton> photons_host_;
  Set sets_[2];
  pb::gpu::Buffer photons_, accum_, stats_, pixel_map_;
  pb::gpu::Image combined_;
  pb::gpu::Pipeline reuse_, accumulate_, resolve_;
};

// More light paths cost more to trace and accumulate and lower the error; a larger radius cap
// gathers each photon into more CPs (longer walks) and trades variance for bias.
const pb_budget_knob kBudget[] = {
    {"light_paths", PB_COST_GROWS, PB_ERROR_FALLS, PB_SCALE_LOG},
    {"radius_cap", PB_COST_GROWS, PB_ERROR_MIXED, PB_SCALE_LOG},
};

}  // namespace

// The shared direct light's rows (the toolkit's: shadow maps or many-light next-event estimation,
// seed 002 Papers III and IV) after the technique's own.
constexpr auto kSchema = pb::join_rows(kParams, pb::toolkit::kDirectLightParams);

PB_EXPORT_TECHNIQUE(CollectionPoints, "collection-points", "indirect_caustics",
                    "Paper V of seed 002: collection points at the camera paths' first diffuse "
                    "vertex, through mirrors and glass, in a GPU BVH rebuilt (or refitted) each "
                    "frame; caustic photons summed by point walks in fixed point",
                    kSchema.rows, .counters = kCounters.specs, .check = &CollectionPoints::check,
                    .budget = kBudget)
