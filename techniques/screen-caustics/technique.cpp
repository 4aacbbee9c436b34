// screen-caustics: seed 001 (a 2004 thesis), Ch. 12, "Hardware-optimised real-time caustics".
// Caustic photons, Halton points aimed at the specular objects, are traced on the CPU and drawn on
// the GPU as points into a screen-space count buffer, which a 7 x 7 filter turns into caustic
// radiance where a screen grid finds photons. Per frame:
//   trace   the tracer's aimed emission (PhotonTracer::aimed_emission_densities) places this
//           frame's slice of the Halton photons; 1 / retrace_frames of them re-traced, round robin,
//           the rest kept from earlier frames (Ch. 12, Ch. 14: 10,000 over 8 frames) (CPU);
//   upload  the kept photons' hits;
//   points  each drawn as a point into the count buffer, depth tested against the G-buffer, 8-bit
//           counts saturating at 255 (steps 1-2) (GPU);
//   grid    a 10 x 10 screen grid: cells with no photon within the filter's reach are written 0 and
//           skipped (step 4, the thesis's occlusion queries) (GPU; the active cells read back);
//   filter  Eq. 12.1's filter of the counts over the active cells, the photons' mean flux over
//           Eq. 12.2's pixel area, times albedo / pi (steps 5-6) (GPU).
// README.md gives the parameters, counters, deviations and measured figures. When it fails: a
// fixed screen-space radius blurs a caustic seen close and dims one seen from afar (without the
// area term); photons of several colours share the mean colour; caustics of indirect light are
// not captured (photons aimed at specular objects only).
#include "photonbench/toolkit/technique.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "photonbench/plugin.h"
#include "screen-caustics_shaders.h"
#include "screen_caustics.h"

namespace {

namespace tk = pb::toolkit;
using pb::gpu::Binding;
using sc::kParams;
using sc::ScParams;

static_assert(sizeof(sc::ScPush) == 96, "std430 size of ScPush");
static_assert(kParams.member_defaults_match());

constexpr auto kCounters = pb::counters({
    {"photons_traced", PB_COUNTER_WORK, "paths", "caustic light paths traced this frame"},
    tk::kPhotonsStoredCounter,
    {"photons_kept", PB_COUNTER_SIZE, "photons", "caustic photons drawn: this frame's and kept"},
    {"points_drawn", PB_COUNTER_WORK, "points", "photons that passed the depth test"},
    {"points_occluded", PB_COUNTER_WORK, "points",
     "photons behind the visible surface or off screen"},
    {"cells_active", PB_COUNTER_SIZE, "cells",
     "grid cells with a photon within the filter's reach"},
    {"cells_skipped", PB_COUNTER_SIZE, "cells", "grid cells the filter skipped"},
    {"saturated_pixels", PB_COUNTER_SIZE, "pixels", "pixels holding more than 255 photons"},
    {"bytes_total", PB_COUNTER_SIZE, "bytes", "GPU memory of the technique's buffers and image"},
});

class ScreenCaustics final : public pb::Technique {
 public:
  void setup(pb::Context& ctx, const pb::Params& params) override {
    p_ = kParams.read(params);
    pb::toolkit::configure_direct_light(ctx, params);
    tk::configure_shadows(ctx, p_.shadow_map_size);
    pb::gpu::Device& gpu = ctx.gpu();
    width_ = ctx.output().extent().width;
    height_ = ctx.output().extent().height;
    grid_ = std::min({p_.grid, width_, height_});
    trace_.store = pb::trace::kCausticPhotons;
    trace_.max_bounces = p_.max_bounces;
    trace_.emission = &emission_;
    slots_.assign(p_.retrace_frames, {});
    std::vector<Binding> bindings(6, Binding::storage_buffer);
    bindings.insert(bindings.end(), 4, Binding::storage_image);
    auto make = [&](const char* name, std::span<const uint32_t> spirv) {
      return gpu.create_compute_pipeline(std::string("screen-caustics/") + name, spirv, bindings,
                                         sizeof(sc::ScPush));
    };
    points_ = make("points", ksc_points_comp_spv);
    grid_pass_ = make("grid", ksc_grid_comp_spv);
    filter_ = make("filter", ksc_filter_comp_spv);
    caustics_ = gpu.create_image("screen-caustics/caustics", {width_, height_},
                                 vk::Format::eR32G32B32A32Sfloat, vk::ImageUsageFlagBits::eStorage);
    const uint64_t pixels = uint64_t(width_) * height_;
    tk::check_storage_range(gpu, pixels * 4, fmt::format("screen-caustics: {} pixels", pixels));
    counts_ = tk::storage_buffer(gpu, "screen-caustics/counts", pixels * 4,
                                 pb::gpu::Memory::host_visible);
    stats_ = tk::storage_buffer(gpu, "screen-caustics/stats", SC_STAT_WORDS * 4,
                                pb::gpu::Memory::host_visible);
    const uint64_t cells = uint64_t(grid_) * grid_;
    cell_active_ = tk::storage_buffer(gpu, "screen-caustics/cell-active", cells * 4,
                                      pb::gpu::Memory::host_visible);
    active_cells_ = tk::storage_buffer(gpu, "screen-caustics/active-cells", cells * 4,
                                       pb::gpu::Memory::host_visible);
    const uint64_t photon_bytes = std::max<uint64_t>(1, p_.photons) * 16;
    tk::check_storage_range(gpu, photon_bytes,
                            fmt::format("screen-caustics: photons = {}", p_.photons));
    photons_ = tk::storage_buffer(gpu, "screen-caustics/photons", photon_bytes,
                                  pb::gpu::Memory::host_visible);
  }

  void render(pb::Context& ctx) override {
    uint64_t traced = 0, stored = 0;
    {
      auto scope = ctx.pass("trace");
      pb::trace::PhotonTracer& tracer = ctx.photon_tracer();
      emission_.configure(tracer.aimed_emission_densities(), p_.photons, p_.retrace_frames);
      // The first frame traces every slice, as the thesis's demo has them from before it starts.
      const uint32_t first = frames_ == 0 ? 0 : frames_ % p_.retrace_frames;
      const uint32_t last = frames_ == 0 ? p_.retrace_frames : first + 1;
      for (uint32_t s = first; s < last; ++s) {
        emission_.select_slice(s);
        tracer.trace(trace_, batch_);
        traced += batch_.stats.paths;
        stored += batch_.photons.size();
        Slot& slot = slots_[s];
        slot.positions.clear();
        slot.power = glm::dvec3(0.0);
        for (const pb::trace::PhotonRecord& r : batch_.photons) {
          slot.positions.push_back(glm::vec4(r.position, 1.f));
          slot.power += glm::dvec3(r.power);
        }
      }
    }
    glm::dvec3 power(0.0);
    uint32_t kept = 0;
    {
      auto scope = ctx.pass("upload");
      auto* out = static_cast<glm::vec4*>(photons_.mapped());
      for (const Slot& slot : slots_) {
        const size_t n = std::min<size_t>(slot.positions.size(), p_.photons - kept);
        std::memcpy(out + kept, slot.positions.data(), n * sizeof(glm::vec4));
        kept += uint32_t(n);
        power += slot.power;
      }
    }
    ctx.shared().gbuffer();
    ctx.shared().direct_light();

    const pb::FrameInfo& frame = ctx.frame();
    sc::ScPush push{};
    push.width = width_;
    push.height = height_;
    push.photons = kept;
    push.count_precision =
        p_.count_precision == sc::CountPrecision::bits8 ? SC_PRECISION_8BIT : SC_PRECISION_FLOAT;
    push.grid = grid_;
    push.cell_width = (width_ + grid_ - 1) / grid_;
    push.cell_height = (height_ + grid_ - 1) / grid_;
    push.area_scaling = uint32_t(p_.area_scaling);
    push.flux = kept > 0 ? glm::vec3(power / double(kept)) : glm::vec3(0.f);
    push.k = int(p_.filter_k);
    push.view_forward =
        glm::normalize(glm::vec3(glm::inverse(frame.camera.view) * glm::vec4(0.f, 0.f, -1.f, 0.f)));
    push.weight_sum = sc::sc_weight_sum(push.k);
    const float tan_y = std::tan(0.5f * frame.camera.fov_y);
    push.pixel_tan_y = tan_y / float(height_);
    push.pixel_tan_x = tan_y * float(width_) / float(height_) / float(width_);
    push.depth_tolerance = p_.depth_tolerance;
    push.tiles_per_cell_x = pb::gpu::groups_for(push.cell_width, 8);
    push.tiles_per_cell_y = pb::gpu::groups_for(push.cell_height, 8);

    const pb::GBuffer g = ctx.shared().gbuffer_images();
    const std::vector<pb::gpu::Resource> resources{
        &photons_,  &counts_, &stats_,  &cell_active_, &active_cells_, &ctx.shared().frame_buffer(),
        g.position, g.normal, g.albedo, &caustics_};
    auto dispatch = [&](const pb::gpu::Pipeline& pipeline, uint32_t x, uint32_t y) {
      if (x == 0 || y == 0) return;
      vk::CommandBuffer c = ctx.cmd();
      pipeline.bind(c, std::span<const pb::gpu::Resource>(resources), push);
      c.dispatch(x, y, 1);
      pb::gpu::full_barrier(c);
    };
    {
      auto scope = ctx.pass("points");
      vk::CommandBuffer cmd = ctx.cmd();
      cmd.fillBuffer(counts_.handle(), 0, VK_WHOLE_SIZE, 0u);
      cmd.fillBuffer(stats_.handle(), 0, VK_WHOLE_SIZE, 0u);
      pb::gpu::full_barrier(cmd);
      dispatch(points_, pb::gpu::groups_for(kept, 64), 1);
    }
    uint32_t active = 0;
    {
      // The thesis reads its occlusion queries back before it draws the filter's quads.
      auto scope = ctx.pass("grid");
      dispatch(grid_pass_, grid_, grid_);
      ctx.flush();
      const auto* flags = static_cast<const uint32_t*>(cell_active_.mapped());
      auto* list = static_cast<uint32_t*>(active_cells_.mapped());
      for (uint32_t c = 0; c < grid_ * grid_; ++c)
        if (flags[c] != 0) list[active++] = c;
    }
    {
      auto scope = ctx.pass("filter");
      dispatch(filter_, push.tiles_per_cell_x * push.tiles_per_cell_y, active);
    }
    ctx.shared().shade(&caustics_);
    ctx.flush();
    const auto* s = static_cast<const uint32_t*>(stats_.mapped());
    const auto* counts = static_cast<const uint32_t*>(counts_.mapped());
    uint32_t saturated = 0;
    for (uint64_t i = 0; i < uint64_t(width_) * height_; ++i) saturated += counts[i] > 255u;
    pb::count(ctx, kCounters["photons_traced"], double(traced));
    pb::count(ctx, tk::kPhotonsStoredCounter, double(stored));
    pb::count(ctx, kCounters["photons_kept"], kept);
    pb::count(ctx, kCounters["points_drawn"], s[SC_STAT_POINTS_DRAWN]);
    pb::count(ctx, kCounters["points_occluded"], s[SC_STAT_POINTS_OCCLUDED]);
    pb::count(ctx, kCounters["cells_active"], active);
    pb::count(ctx, kCounters["cells_skipped"], grid_ * grid_ - active);
    pb::count(ctx, kCounters["saturated_pixels"], saturated);
    pb::count(ctx, kCounters["bytes_total"],
              double(caustics_.bytes() + counts_.size() + stats_.size() + cell_active_.size() +
                     active_cells_.size() + photons_.size()));
    ++frames_;
  }

 private:
  struct Slot {  // one round-robin slice's photons, kept until it is re-traced
    std::vector<glm::vec4> positions;
    glm::dvec3 power{0.0};
  };
  ScParams p_;
  uint32_t width_ = 0, height_ = 0, grid_ = 1, frames_ = 0;
  sc::HaltonEmission emission_;
  pb::trace::TraceSettings trace_;
  pb::trace::PhotonBatch batch_;
  std::vector<Slot> slots_;
  pb::gpu::Buffer photons_, counts_, stats_, cell_active_, active_cells_;
  pb::gpu::Image caustics_;
  pb::gpu::Pipeline points_, grid_pass_, filter_;
};

// More photons cost more to trace and draw and lower the error; a wider filter costs more per
// active pixel and trades variance for bias.
const pb_budget_knob kBudget[] = {
    {"photons", PB_COST_GROWS, PB_ERROR_FALLS, PB_SCALE_LOG},
    {"filter_k", PB_COST_GROWS, PB_ERROR_MIXED, PB_SCALE_LINEAR},
};

}  // namespace

// The shared direct light's rows after the technique's own.
constexpr auto kSchema = pb::join_rows(kParams, pb::toolkit::kDirectLightParams);

PB_EXPORT_TECHNIQUE(ScreenCaustics, "screen-caustics", "caustics",
                    "seed 001 Ch. 12: Halton caustic photons aimed at specular objects, re-traced "
                    "over frames, drawn as points into a screen-space count buffer and filtered "
                    "7 x 7 over the grid cells that hold photons, with the pixel-area term",
                    kSchema.rows, .counters = kCounters.specs, .budget = kBudget)
