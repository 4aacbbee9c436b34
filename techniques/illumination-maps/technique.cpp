// illumination-maps: seed 001 (a 2004 thesis), Ch. 8, 10 and 11: indirect diffuse light from
// photons stored per chart, estimated into small approximated illumination maps (AIMs) and final
// gathered at each texel into indirect illumination maps (IIMs) that the screen looks up. Per
// frame:
//   photon-trace  photons at every diffuse hit (direct and indirect: the AIMs hold the surfaces'
//                 full reflected light, Ch. 10): with `emission: selective` (Ch. 9) the toolkit's
//                 SelectiveEmission keeps fixed Halton paths, probes one per group and re-traces
//                 the diverged groups; with `fresh` the tracer's new paths every frame (CPU);
//   charts        on the first frame and when the scene's triangles change: segment_charts' crease
//                 angle partition (Ch. 8), a texel grid per chart, each texel's centre (CPU);
//   kd-trees      the photons split by their hit triangle's chart, one photon map each (Ch. 8);
//                 selective: only the charts whose kept photons changed (the ledger, by chart);
//   aims          the charts whose flux per area moved most (|delta f| / A over a threshold, at
//                 most charts_per_frame): each texel the N nearest photons' radiance (Ch. 10);
//   gather        the texels whose AIM input moved most (at most gather_texels): raster draws the
//                 scene onto a hemi-plane per texel into an atlas (draw_scene), weighs each pixel's
//                 AIM radiance by Eq. 11.2 and sums by MIP reduction, 8-bit or float (GPU); rays
//                 casts cosine-distributed rays with Embree (CPU);
//   iim-blend     the displayed IIM moves `blend` of the way to the newest gathered (double
//                 buffer);
//   lookup        the camera's triangles (draw_scene), each pixel's IIM irradiance times albedo /
//                 pi into class_output("indirect") and shade() (GPU).
// README.md gives the parameters, counters, deviations and measured figures. When it fails: the
// texels are large (5 along a wall), so indirect light is smooth and blocky at contact; specular
// surfaces hold no AIM, so light through them is not gathered; a chart that turns more than 90
// degrees folds its planar parameterisation onto itself.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "illumination-maps_shaders.h"
#include "illumination_maps.h"
#include "photonbench/plugin.h"

namespace {

namespace tk = pb::toolkit;
using im::kParams;
using pb::gpu::Binding;

static_assert(sizeof(im::ImPush) == 64, "std430 size of ImPush");
static_assert(sizeof(im::ImChart) == 32, "std430 size of ImChart");
static_assert(kParams.member_defaults_match());

constexpr float kHalfWidth = 2.0f;  // Ch. 11: the hemi-cube's front face, doubled in side

constexpr auto kCounters = pb::counters({
    tk::kPhotonsStoredCounter,
    tk::kProbesCounter,
    tk::kGroupsInvalidatedCounter,
    tk::kPathsRetracedCounter,
    tk::kSelectiveRaysCounter,
    {"trace_rays", PB_COUNTER_WORK, "rays",
     "rays of the frame's photon trace (fresh: every path; selective: probes and re-traces)"},
    {"maps_rebuilt", PB_COUNTER_WORK, "charts", "charts whose photon map was rebuilt this frame"},
    {"charts_changed", PB_COUNTER_WORK, "charts",
     "selective: charts whose kept photons changed (the ledger's changed surfaces)"},
    {"charts_rebuilt", PB_COUNTER_WORK, "charts",
     "charts a rebuild of the charts (the scene's triangles moved) started afresh: all, or with "
     "selective emission the moved ones"},
    {"charts", PB_COUNTER_SIZE, "charts", "charts of the crease-angle partition (Ch. 8)"},
    {"texels", PB_COUNTER_SIZE, "texels", "AIM (and IIM) texels over all charts"},
    {"photons_per_chart", PB_COUNTER_SIZE, "photons", "photons stored per chart, the mean"},
    {"photons_per_chart_max", PB_COUNTER_SIZE, "photons", "photons of the fullest chart"},
    {"charts_updated", PB_COUNTER_WORK, "charts", "AIMs recomputed this frame"},
    {"texels_gathered", PB_COUNTER_WORK, "texels", "IIM texels final gathered this frame"},
    {"bytes_total", PB_COUNTER_SIZE, "bytes",
     "GPU memory of the technique's buffers and images, and the CPU photon maps"},
});

struct DrawTarget {
  pb::gpu::Image position, normal, triangle, depth;
  void make(pb::gpu::Device& gpu, const std::string& name, vk::Extent2D extent) {
    using I = vk::ImageUsageFlagBits;
    const auto usage = I::eColorAttachment | I::eStorage | I::eTransferSrc;
    position = gpu.create_image(name + "/position", extent, vk::Format::eR32G32B32A32Sfloat, usage);
    normal = gpu.create_image(name + "/normal", extent, vk::Format::eR32G32B32A32Sfloat, usage);
    triangle = gpu.create_image(name + "/triangle", extent, vk::Format::eR32Uint, usage);
    depth = gpu.create_image(name + "/depth", extent, vk::Format::eD32Sfloat,
                             I::eDepthStencilAttachment);
  }
  pb::SceneTarget target(vk::Rect2D area = {}) const {
    return pb::SceneTarget{&position, &normal, &triangle, &depth, area};
  }
  uint64_t bytes() const {
    return position.bytes() + normal.bytes() + triangle.bytes() + depth.bytes();
  }
};

class IlluminationMaps final : public pb::Technique {
 public:
  static std::string check(const pb::Params& params) { return im::check(params); }

  void setup(pb::Context& ctx, const pb::Params& params) override {
    p_ = kParams.read(params);
    tk::configure_direct_light(ctx, params);
    tk::configure_shadows(ctx, p_.shadow_map_size);
    pb::gpu::Device& gpu = ctx.gpu();
    width_ = ctx.output().extent().width;
    height_ = ctx.output().extent().height;
    trace_.paths = p_.paths;
    trace_.max_bounces = p_.max_bounces;
    trace_.store = pb::trace::kAllPhotons;
    std::vector<Binding> bindings(7, Binding::storage_buffer);
    bindings.insert(bindings.end(), 5, Binding::storage_image);
    auto make = [&](const char* name, std::span<const uint32_t> spirv) {
      return gpu.create_compute_pipeline(std::string("illumination-maps/") + name, spirv, bindings,
                                         sizeof(im::ImPush));
    };
    weigh_ = make("weigh", kim_weigh_comp_spv);
    reduce_ = make("reduce", kim_reduce_comp_spv);
    lookup_ = make("lookup", kim_lookup_comp_spv);
    camera_.make(gpu, "illumination-maps/camera", {width_, height_});
  }

  void render(pb::Context& ctx) override {
    pb::gpu::Device& gpu = ctx.gpu();
    if (albedo_.empty()) read_albedo(ctx);
    const pb::SceneTriangles triangles = ctx.shared().scene_triangles();
    const bool rebuild = frames_ == 0 || triangles.changed_frame != built_frame_;
    if (rebuild) {
      auto scope = ctx.pass("charts");
      maps_.build(triangles, albedo_, p_.crease_angle, p_.aim_texels,
                  p_.emission == im::Emission::selective);
      built_frame_ = triangles.changed_frame;
      caster_ = std::make_unique<tk::TriangleRayCaster>(triangles);
      upload_charts(gpu, triangles);
      // The ledger is keyed by chart id: a new partition starts the kept paths afresh.
      const auto chart_of = maps_.chart_of();
      if (p_.emission == im::Emission::selective &&
          (!selective_ || !std::ranges::equal(chart_of, selective_chart_of_))) {
        selective_chart_of_.assign(chart_of.begin(), chart_of.end());
        selective_ = std::make_unique<tk::SelectiveEmission>(
            ctx.photon_tracer(), im::selective_settings(p_), selective_chart_of_);
      }
    }
    uint64_t stored = 0, trace_rays = 0, maps_rebuilt = 0;
    tk::SelectiveEmissionStats selective_stats;
    {
      auto scope = ctx.pass("photon-trace");
      if (selective_) {
        selective_stats = selective_->update();
        trace_rays = selective_stats.rays();
      } else {
        trace_rays = ctx.photon_tracer().trace(trace_, batch_).rays;
        stored = batch_.photons.size();
      }
    }
    {
      auto scope = ctx.pass("kd-trees");
      if (selective_) {
        // Ch. 9 with Ch. 10: only the charts whose kept photons changed get a new map, and after
        // a rebuild of the charts the ones it started afresh (moved, or all on a new partition).
        batch_.photons = selective_->photons();
        stored = batch_.photons.size();
        const auto changed = selective_->changed_surfaces();
        std::vector<uint32_t> charts(changed.begin(), changed.end());
        if (rebuild) {
          const auto moved = maps_.fresh_charts();
          std::vector<uint32_t> both;
          std::ranges::set_union(charts, moved, std::back_inserter(both));
          charts = std::move(both);
        }
        maps_.store_chart_photons(batch_.photons, charts, selective_->ledger());
        maps_rebuilt = charts.size();
      } else {
        maps_.store_photons(batch_.photons);
        maps_rebuilt = maps_.charts().size();
      }
    }
    uint32_t charts_updated = 0;
    {
      auto scope = ctx.pass("aims");
      // Every chart with no AIM yet (all on the first frame and after a rebuild of the charts,
      // the moved ones with selective emission), then at most charts_per_frame by their change.
      charts_updated = maps_.update_aims(maps_.charts_without_aim() + p_.charts_per_frame,
                                         p_.aim_threshold, p_.aim_photons, p_.aim_estimate);
      std::memcpy(aim_.mapped(), maps_.aim().data(), maps_.aim().size_bytes());
      auto* normals = static_cast<glm::vec4*>(texel_normals_.mapped());
      const auto sites = maps_.sites();
      for (size_t t = 0; t < sites.size(); ++t) normals[t] = glm::vec4(sites[t].normal, 0.f);
    }
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    const pb::GBuffer g = ctx.shared().gbuffer_images();
    const pb::gpu::Image& indirect = ctx.class_output("indirect");

    // Every texel never gathered (all on the first frame), then at most gather_texels.
    const std::vector<uint32_t> texels =
        maps_.take_gather_texels(maps_.texels_never_gathered() + p_.gather_texels);
    {
      auto scope = ctx.pass("gather");
      if (p_.gather == im::Gather::rays) {
        for (uint32_t t : texels) back_[t] = maps_.gather_rays(t, *caster_, p_.gather_rays);
      } else {
        gather_raster(ctx, texels, g, indirect);
      }
    }
    {
      auto scope = ctx.pass("iim-blend");
      for (uint32_t t : texels) {
        if (!shown_[t]) front_[t] = back_[t];  // a texel's first value is shown at once
        shown_[t] = true;
      }
      for (uint32_t t = 0; t < maps_.texel_count(); ++t)
        front_[t] += p_.blend * (back_[t] - front_[t]);
      auto* out = static_cast<glm::vec4*>(iim_.mapped());
      for (uint32_t t = 0; t < maps_.texel_count(); ++t) out[t] = glm::vec4(front_[t], 0.f);
    }
    {
      auto scope = ctx.pass("lookup");
      ctx.shared().draw_scene(camera_.target());
      pb::gpu::full_barrier(ctx.cmd());
      im::ImPush push = base_push();
      push.width = width_;
      push.height = height_;
      dispatch(ctx, lookup_, camera_, level_a_, level_b_, g, indirect, push,
               pb::gpu::groups_for(width_, 8), pb::gpu::groups_for(height_, 8));
    }
    ctx.shared().shade(&indirect);

    uint64_t photons_max = 0, map_bytes = 0;
    for (const im::ChartMap& m : maps_.charts()) {
      photons_max = std::max<uint64_t>(photons_max, m.positions.size());
      map_bytes += m.tree.bytes();
    }
    const double charts = double(maps_.charts().size());
    pb::count(ctx, tk::kPhotonsStoredCounter, double(stored));
    tk::report(ctx, selective_stats);
    pb::count(ctx, kCounters["trace_rays"], double(trace_rays));
    pb::count(ctx, kCounters["maps_rebuilt"], double(maps_rebuilt));
    pb::count(ctx, kCounters["charts_rebuilt"],
              rebuild ? double(maps_.fresh_charts().size()) : 0.0);
    pb::count(ctx, kCounters["charts_changed"],
              selective_ ? double(selective_->changed_surfaces().size()) : 0.0);
    pb::count(ctx, kCounters["charts"], charts);
    pb::count(ctx, kCounters["texels"], maps_.texel_count());
    pb::count(ctx, kCounters["photons_per_chart"], charts > 0 ? double(stored) / charts : 0.0);
    pb::count(ctx, kCounters["photons_per_chart_max"], double(photons_max));
    pb::count(ctx, kCounters["charts_updated"], charts_updated);
    pb::count(ctx, kCounters["texels_gathered"], double(texels.size()));
    pb::count(ctx, kCounters["bytes_total"],
              double(camera_.bytes() + atlas_.bytes() + triangle_chart_.size() + charts_.size() +
                     aim_.size() + iim_.size() + texel_normals_.size() + level_a_.size() +
                     level_b_.size() + map_bytes));
    ++frames_;
  }

 private:
  // The materials' albedo, read back once from the shared material buffer.
  void read_albedo(pb::Context& ctx) {
    const pb::gpu::Buffer& materials = ctx.shared().material_buffer();
    pb::gpu::Buffer host = tk::storage_buffer(ctx.gpu(), "illumination-maps/materials",
                                              materials.size(), pb::gpu::Memory::host_visible);
    vk::CommandBuffer cmd = ctx.cmd();
    pb::gpu::full_barrier(cmd);
    cmd.copyBuffer(materials.handle(), host.handle(), vk::BufferCopy{0, 0, materials.size()});
    ctx.flush();
    const auto* records = static_cast<const pb::layout::GpuMaterial*>(host.mapped());
    const size_t count = materials.size() / sizeof(pb::layout::GpuMaterial);
    albedo_.resize(count);
    for (size_t m = 0; m < count; ++m) albedo_[m] = glm::vec3(records[m].albedo_type);
  }

  void upload_charts(pb::gpu::Device& gpu, const pb::SceneTriangles& triangles) {
    const uint32_t texels = maps_.texel_count();
    const auto chart_of = maps_.chart_of();
    triangle_chart_ = tk::storage_buffer(gpu, "illumination-maps/triangle-chart",
                                         std::max<uint64_t>(1, chart_of.size()) * 4,
                                         pb::gpu::Memory::host_visible);
    std::memcpy(triangle_chart_.mapped(), chart_of.data(), chart_of.size_bytes());
    const auto charts = maps_.charts();
    charts_ = tk::storage_buffer(gpu, "illumination-maps/charts",
                                 std::max<size_t>(1, charts.size()) * sizeof(im::ImChart),
                                 pb::gpu::Memory::host_visible);
    auto* grids = static_cast<im::ImChart*>(charts_.mapped());
    for (size_t c = 0; c < charts.size(); ++c) grids[c] = charts[c].grid;
    const uint64_t texel_bytes = std::max<uint64_t>(1, texels) * sizeof(glm::vec4);
    aim_ = tk::storage_buffer(gpu, "illumination-maps/aim", texel_bytes,
                              pb::gpu::Memory::host_visible);
    iim_ = tk::storage_buffer(gpu, "illumination-maps/iim", texel_bytes,
                              pb::gpu::Memory::host_visible);
    texel_normals_ = tk::storage_buffer(gpu, "illumination-maps/texel-normals", texel_bytes,
                                        pb::gpu::Memory::host_visible);
    // Texels of the charts a selective rebuild kept keep their IIM values.
    const std::vector<glm::vec3> front = std::move(front_), back = std::move(back_);
    const std::vector<bool> shown = std::move(shown_);
    front_.assign(texels, glm::vec3(0.f));
    back_.assign(texels, glm::vec3(0.f));
    shown_.assign(texels, false);
    const auto before = maps_.texel_before();
    for (uint32_t t = 0; t < texels; ++t)
      if (before[t] != im::IlluminationMaps::kNoTexel && before[t] < front.size()) {
        front_[t] = front[before[t]];
        back_[t] = back[before[t]];
        shown_[t] = shown[before[t]];
      }
    // The scene's size bounds the hemi-plane cameras' depth range.
    glm::vec3 lo(1e30f), hi(-1e30f);
    for (const auto& v : triangles.host_vertices) {
      lo = glm::min(lo, glm::vec3(v.position));
      hi = glm::max(hi, glm::vec3(v.position));
    }
    far_ = 2.f * std::max(1e-3f, glm::length(hi - lo));
    // The atlas holds every texel's hemi-plane (the first frame gathers all) up to 4096^2 pixels;
    // more are gathered in several rounds.
    const uint32_t most = std::max(1u, 4096u / p_.hemi_size);
    capacity_ = std::max(1u, std::min(texels, most * most));
    planes_per_row_ = std::min(most, uint32_t(std::ceil(std::sqrt(double(capacity_)))));
    const uint32_t rows = (capacity_ + planes_per_row_ - 1) / planes_per_row_;
    if (p_.gather == im::Gather::raster) {
      atlas_.make(gpu, "illumination-maps/atlas",
                  {planes_per_row_ * p_.hemi_size, rows * p_.hemi_size});
      const uint64_t pixels = uint64_t(capacity_) * p_.hemi_size * p_.hemi_size;
      tk::check_storage_range(gpu, pixels * 16,
                              fmt::format("illumination-maps: {} hemi-plane pixels", pixels));
      level_a_ = tk::storage_buffer(gpu, "illumination-maps/level-a", pixels * 16,
                                    pb::gpu::Memory::host_visible);
      level_b_ =
          tk::storage_buffer(gpu, "illumination-maps/level-b", std::max<uint64_t>(16, pixels * 4),
                             pb::gpu::Memory::host_visible);
    } else if (level_a_.size() == 0) {
      // The lookup's binding list still names two level buffers.
      level_a_ = tk::storage_buffer(gpu, "illumination-maps/level-a", 16);
      level_b_ = tk::storage_buffer(gpu, "illumination-maps/level-b", 16);
    }
    weight_sum_ = float(im::hemi_plane_weight_sum(p_.hemi_size, kHalfWidth));
  }

  im::ImPush base_push() const {
    im::ImPush push{};
    push.hemi_size = p_.hemi_size;
    push.planes_per_row = planes_per_row_;
    push.sum_precision = p_.sum_precision == im::SumPrecision::bits8 ? IM_SUM_8BIT : IM_SUM_FLOAT;
    push.half_width = kHalfWidth;
    push.weight_sum = weight_sum_;
    return push;
  }

  void dispatch(pb::Context& ctx, const pb::gpu::Pipeline& pipeline, const DrawTarget& drawn,
                const pb::gpu::Buffer& level_in, const pb::gpu::Buffer& level_out,
                const pb::GBuffer& g, const pb::gpu::Image& indirect, const im::ImPush& push,
                uint32_t x, uint32_t y) {
    if (x == 0 || y == 0) return;
    const std::vector<pb::gpu::Resource> resources{
        &triangle_chart_, &charts_,        &aim_,         &iim_,           &level_in, &level_out,
        &texel_normals_,  &drawn.position, &drawn.normal, &drawn.triangle, g.albedo,  &indirect};
    vk::CommandBuffer c = ctx.cmd();
    pipeline.bind(c, std::span<const pb::gpu::Resource>(resources), push);
    c.dispatch(x, y, 1);
    pb::gpu::full_barrier(c);
  }

  // Ch. 11's gather for `texels`, in rounds of the atlas's capacity: each texel's hemi-plane drawn
  // into the atlas, weighed (level 0), reduced level by level to 1 x 1, read back.
  void gather_raster(pb::Context& ctx, const std::vector<uint32_t>& texels, const pb::GBuffer& g,
                     const pb::gpu::Image& indirect) {
    float largest = 0;
    for (const glm::vec4& a : maps_.aim()) largest = std::max({largest, a.x, a.y, a.z});
    const uint32_t pixels = p_.hemi_size * p_.hemi_size;
    const float scale = im::hemi_plane_scale_8bit(largest, p_.hemi_size, kHalfWidth);
    const auto sites = maps_.sites();
    for (size_t first = 0; first < texels.size(); first += capacity_) {
      const uint32_t planes = uint32_t(std::min<size_t>(capacity_, texels.size() - first));
      for (uint32_t k = 0; k < planes; ++k) {
        const im::TexelSite& site = sites[texels[first + k]];
        const vk::Rect2D area{{int32_t((k % planes_per_row_) * p_.hemi_size),
                               int32_t((k / planes_per_row_) * p_.hemi_size)},
                              {p_.hemi_size, p_.hemi_size}};
        const glm::vec3 eye = site.position + maps_.epsilon() * site.normal;
        ctx.shared().draw_scene(
            atlas_.target(area),
            im::hemi_plane_view_projection(eye, site.normal, kHalfWidth, maps_.epsilon(), far_));
      }
      pb::gpu::full_barrier(ctx.cmd());
      im::ImPush push = base_push();
      push.planes = planes;
      push.scale_8bit = scale;
      dispatch(ctx, weigh_, atlas_, level_b_, level_a_, g, indirect, push,
               pb::gpu::groups_for(uint64_t(planes) * pixels, 64), 1);
      bool in_a = true;
      for (uint32_t s = p_.hemi_size; s > 1; s /= 2) {
        push.level_size = s;
        const uint64_t out = uint64_t(planes) * (s / 2) * (s / 2);
        dispatch(ctx, reduce_, atlas_, in_a ? level_a_ : level_b_, in_a ? level_b_ : level_a_, g,
                 indirect, push, pb::gpu::groups_for(out, 64), 1);
        in_a = !in_a;
      }
      ctx.flush();
      const auto* top = static_cast<const glm::vec4*>((in_a ? level_a_ : level_b_).mapped());
      for (uint32_t k = 0; k < planes; ++k)
        back_[texels[first + k]] =
            im::hemi_plane_irradiance(glm::vec3(top[k]), scale, push.sum_precision, weight_sum_);
    }
  }

  im::ImParams p_;
  uint32_t width_ = 0, height_ = 0, frames_ = 0, built_frame_ = 0;
  uint32_t capacity_ = 1, planes_per_row_ = 1;
  float far_ = 100.f, weight_sum_ = 1.f;
  im::IlluminationMaps maps_;
  std::vector<glm::vec3> albedo_;
  std::unique_ptr<tk::TriangleRayCaster> caster_;
  pb::trace::TraceSettings trace_;
  pb::trace::PhotonBatch batch_;
  std::unique_ptr<tk::SelectiveEmission> selective_;  // emission: selective (Ch. 9)
  std::vector<uint32_t> selective_chart_of_;          // the partition its ledger is keyed by
  std::vector<glm::vec3> front_, back_;               // the displayed IIM and the newest gathered
  std::vector<bool> shown_;
  pb::gpu::Buffer triangle_chart_, charts_, aim_, iim_, texel_normals_, level_a_, level_b_;
  DrawTarget camera_, atlas_;
  pb::gpu::Pipeline weigh_, reduce_, lookup_;
};

// More photons (fresh: paths a frame; selective: photons a group) cost more to trace and lower the
// AIMs' noise; more texels gathered a frame cost more and cut the lag behind a change.
const pb_budget_knob kBudget[] = {
    {"photons", PB_COST_GROWS, PB_ERROR_FALLS, PB_SCALE_LOG},
    {"group_size", PB_COST_GROWS, PB_ERROR_FALLS, PB_SCALE_LOG},
    {"aim_texels", PB_COST_GROWS, PB_ERROR_MIXED, PB_SCALE_LINEAR},
};

}  // namespace

// The shared direct light's rows after the technique's own.
constexpr auto kSchema = pb::join_rows(kParams, pb::toolkit::kDirectLightParams);

PB_EXPORT_TECHNIQUE(IlluminationMaps, "illumination-maps", "indirect",
                    "seed 001 Ch. 8, 10, 11: photons in one kd-tree per crease-angle chart, "
                    "approximated illumination maps of their N-nearest estimates, final gathered "
                    "per texel on a hemi-plane (MIP sum) or by rays into indirect illumination "
                    "maps looked up per pixel",
                    kSchema.rows, .counters = kCounters.specs, .check = &IlluminationMaps::check,
                    .budget = kBudget)
