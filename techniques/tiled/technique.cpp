// tiled: Paper I's version of Mara et al.'s tiled photon splatting (Moreau et al. 2016, §5.1; Mara,
// Luebke & McGuire 2013), the baseline the cluster hierarchy is measured against.
//
// Per frame: photons are traced on the CPU (stored at every diffuse hit but the first, Paper I
// §4.2) and copied to a host-visible storage buffer; after the shared G-buffer and direct light,
// each 32x32 tile gets its view-depth bounds; each photon's sphere of influence is tested against
// the tiles under its screen rectangle (depth overlap), counted per tile, the counts scanned into
// offsets, and the photon indices inserted into per-tile lists; finally each pixel sums the photons
// of its tile's list whose sphere contains it (constant kernel, L = f I / (pi r^2), Paper I §4.4),
// and the shared shade pass adds that indirect radiance to the direct light.
//
// List capacity is a parameter: entries beyond it are dropped on the GPU, counted ("overflows") and
// warned about, never written out of bounds.
#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <glm/glm.hpp>

#include "photonbench/context.h"
#include "photonbench/error.h"
#include "photonbench/plugin.h"
#include "tiled_shaders.h"

namespace {

using pb::gpu::Binding;
using pb::gpu::Buffer;
using pb::gpu::Memory;
using U = vk::BufferUsageFlagBits;

const pb_param_spec kParams[] = {
    {"photons", PB_PARAM_INT, 100000, 1, 5e7, nullptr, "paths",
     "light paths traced per frame (Paper I counts stored photons; default kept small for "
     "lavapipe)"},
    {"radius", PB_PARAM_FLOAT, 0.05, 1e-5, 1e4, nullptr, "m", "photon sphere radius; default 0.05"},
    {"tile_size", PB_PARAM_INT, 32, 8, 256, nullptr, "pixels",
     "tile side, a multiple of 8; Paper I §5.1 uses 32"},
    {"max_list_entries", PB_PARAM_INT, 1 << 22, 1, 1 << 28, nullptr, "entries",
     "capacity of all per-tile lists together (photon indices); overflowing entries are dropped "
     "and counted"},
    {"max_bounces", PB_PARAM_INT, 4, 2, 31, nullptr, "hits",
     "surface interactions per light path; Paper I §4.2 limits tracing to four bounces"},
    {"shadow_map_size", PB_PARAM_INT, 512, 16, 4096, nullptr, "texels",
     "shadow-map tile side of the direct light"},
};

// Mirrors the push block of shaders/tiled_common.h (std430 push constants: mat4, vec4, 8 uint, 4
// float).
struct Push {
  glm::mat4 view_projection;
  glm::vec4 depth_plane;
  uint32_t width, height, tiles_x, tiles_y;
  uint32_t photon_count, tile_size, capacity, tile_count;
  float radius;
  uint32_t list_first = 0, list_slice = 0, pad0 = 0;
};
static_assert(sizeof(Push) == 128);

// Word indices of the stats buffer (shaders/tiled_common.h).
// List entries one radiance-estimate dispatch reads per pixel at most: llvmpipe ends an
// invocation's loops after 65535 iterations in all, so longer lists are read in several dispatches.
constexpr uint32_t kListSlice = 32768;

constexpr uint32_t kStatEntries = 0, kStatDropped = 1, kStatRead = 2, kStatRejected = 4,
                   kStatWords = 8;

class Tiled final : public pb::Technique {
 public:
  void setup(pb::Context& ctx, const pb::Params& params) override {
    paths_ = uint32_t(params.integer("photons"));
    radius_ = float(params.number("radius"));
    tile_size_ = uint32_t(params.integer("tile_size"));
    capacity_ = uint32_t(params.integer("max_list_entries"));
    max_bounces_ = uint32_t(params.integer("max_bounces"));
    if (tile_size_ % 8 != 0)
      throw pb::InputError(
          "tiled: tile_size = " + std::to_string(tile_size_) +
          " must be a multiple of 8 (the 8x8 work groups of tile-bounds must lie in one tile)");
    ctx.shared().configure_shadows(uint32_t(params.integer("shadow_map_size")), 0.01f, 0.01f);
    // The lists are one storage-buffer binding: lavapipe allows 128 MiB (maxStorageBufferRange).
    uint64_t limit = ctx.gpu().physical().getProperties().limits.maxStorageBufferRange;
    if (uint64_t(capacity_) * 4 > limit)
      throw pb::InputError(fmt::format(
          "tiled: max_list_entries = {} (4 bytes each) exceeds the device's maxStorageBufferRange of {} "
          "bytes",
          capacity_, limit));

    auto& gpu = ctx.gpu();
    constexpr uint32_t kPush = sizeof(Push);
    auto B = Binding::storage_buffer;
    auto I = Binding::storage_image;
    bounds_pipeline_ =
        gpu.create_compute_pipeline("tile-bounds", ktile_bounds_comp_spv, {I, B}, kPush);
    count_pipeline_ =
        gpu.create_compute_pipeline("splat-count", ksplat_count_comp_spv, {B, B, B}, kPush);
    scan_pipeline_ =
        gpu.create_compute_pipeline("prefix-sum", kprefix_sum_comp_spv, {B, B, B}, kPush);
    insert_pipeline_ = gpu.create_compute_pipeline("splat-insert", ksplat_insert_comp_spv,
                                                   {B, B, B, B, B, B}, kPush);
    estimate_pipeline_ = gpu.create_compute_pipeline(
        "radiance-estimate", kradiance_estimate_comp_spv, {B, B, B, B, B, I, I, I, I}, kPush);
  }

  void render(pb::Context& ctx) override {
    ensure_resources(ctx);
    auto& gpu = ctx.gpu();
    const auto& frame = ctx.frame();
    pb::trace::TraceSettings settings;
    settings.paths = paths_;
    settings.max_bounces = max_bounces_;
    // Paper I stores every hit but the first; of those we keep the ones the `indirect` path class
    // (C D (D|S)* D (D|S)* L) covers, i.e. without pure caustics L S+ D (README: deviations).
    settings.store = pb::trace::kIndirectPhotons | pb::trace::kCausticIndirectPhotons;
    const uint32_t photon_count =
        pb::trace_and_upload_photons(ctx, settings, batch_, photons_, "tiled/photons");
    ctx.shared().gbuffer();
    ctx.shared().direct_light();

    Push push{};
    push.view_projection = frame.camera.view_projection;
    // View depth along the viewing axis: -(view * p).z for a right-handed view matrix
    // (column-major).
    const glm::mat4& v = frame.camera.view;
    push.depth_plane = -glm::vec4(v[0][2], v[1][2], v[2][2], v[3][2]);
    push.width = width_;
    push.height = height_;
    push.tiles_x = tiles_x_;
    push.tiles_y = tiles_y_;
    push.photon_count = photon_count;
    push.tile_size = tile_size_;
    push.capacity = capacity_;
    push.tile_count = tile_count_;
    push.radius = radius_;

    // ctx.cmd() is fetched anew in every pass: with fenced timing (lavapipe) a pass scope submits
    // and continues in a fresh command buffer.
    auto gbuf = ctx.shared().gbuffer_images();
    {
      auto scope = ctx.pass("tile-bounds");
      auto cmd = ctx.cmd();
      uint32_t n = tile_count_ * 4;
      cmd.fillBuffer(bounds_.handle(), 0, n, 0x7f800000u);  // zmin = +inf
      cmd.fillBuffer(bounds_.handle(), n, n, 0u);           // zmax = 0
      cmd.fillBuffer(stats_.handle(), 0, VK_WHOLE_SIZE, 0u);
      pb::gpu::full_barrier(cmd);
      bounds_pipeline_.bind(cmd, {gbuf.position, &bounds_}, push);
      cmd.dispatch(pb::gpu::groups_for(width_, 8), pb::gpu::groups_for(height_, 8), 1);
    }
    pb::gpu::full_barrier(ctx.cmd());
    {
      auto splat = ctx.pass("splat");
      {
        auto scope = ctx.pass("count");
        auto cmd = ctx.cmd();
        cmd.fillBuffer(counts_.handle(), 0, VK_WHOLE_SIZE, 0u);
        cmd.fillBuffer(cursors_.handle(), 0, VK_WHOLE_SIZE, 0u);
        pb::gpu::full_barrier(cmd);
        count_pipeline_.bind(cmd, {&photons_, &bounds_, &counts_}, push);
        cmd.dispatch(pb::gpu::groups_for(photon_count, 64), 1, 1);
      }
      pb::gpu::full_barrier(ctx.cmd());
      {
        auto scope = ctx.pass("prefix-sum");
        auto cmd = ctx.cmd();
        scan_pipeline_.bind(cmd, {&counts_, &offsets_, &stats_}, push);
        cmd.dispatch(1, 1, 1);
      }
      pb::gpu::full_barrier(ctx.cmd());
      {
        auto scope = ctx.pass("insert");
        auto cmd = ctx.cmd();
        insert_pipeline_.bind(cmd, {&photons_, &bounds_, &offsets_, &cursors_, &lists_, &stats_},
                              push);
        cmd.dispatch(pb::gpu::groups_for(photon_count, 64), 1, 1);
      }
    }
    pb::gpu::full_barrier(ctx.cmd());
    {
      auto scope = ctx.pass("radiance-estimate");
      auto cmd = ctx.cmd();
      // A tile's list holds each photon at most once, so photon_count bounds its length.
      uint32_t slices = std::max<uint32_t>(1, pb::gpu::groups_for(photon_count, kListSlice));
      push.list_slice = kListSlice;
      for (uint32_t slice = 0; slice < slices; ++slice) {
        if (slice > 0) pb::gpu::full_barrier(cmd);
        push.list_first = slice * kListSlice;
        estimate_pipeline_.bind(cmd,
                                {&photons_, &offsets_, &counts_, &lists_, &stats_, gbuf.position,
                                 gbuf.normal, gbuf.albedo, &indirect_},
                                push);
        cmd.dispatch(pb::gpu::groups_for(width_, 8), pb::gpu::groups_for(height_, 8), 1);
      }
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
    tiles_x_ = pb::gpu::groups_for(width_, tile_size_);
    tiles_y_ = pb::gpu::groups_for(height_, tile_size_);
    tile_count_ = tiles_x_ * tiles_y_;

    auto storage = U::eStorageBuffer | U::eTransferDst;
    bounds_ = gpu.create_buffer("tiled/tile-bounds", uint64_t(tile_count_) * 8, storage,
                                Memory::device_local);
    counts_ = gpu.create_buffer("tiled/tile-counts", uint64_t(tile_count_) * 4, storage,
                                Memory::device_local);
    offsets_ = gpu.create_buffer("tiled/tile-offsets", uint64_t(tile_count_) * 4, storage,
                                 Memory::device_local);
    cursors_ = gpu.create_buffer("tiled/tile-cursors", uint64_t(tile_count_) * 4, storage,
                                 Memory::device_local);
    lists_ = gpu.create_buffer("tiled/photon-lists", uint64_t(capacity_) * 4, storage,
                               Memory::device_local);
    stats_ = gpu.create_buffer("tiled/stats", kStatWords * 4, storage, Memory::host_visible);
    indirect_ = gpu.create_image("tiled/indirect", {width_, height_},
                                 vk::Format::eR32G32B32A32Sfloat, vk::ImageUsageFlagBits::eStorage);
  }

  void report(pb::Context& ctx, uint32_t photon_count) {
    auto s = stats_.view<uint32_t>();
    auto wide = [&](uint32_t at) { return double(uint64_t(s[at]) | (uint64_t(s[at + 1]) << 32)); };
    uint64_t entries = s[kStatEntries];
    uint64_t dropped = s[kStatDropped];
    ctx.count("list_entries", double(std::min<uint64_t>(entries, capacity_)));
    ctx.count("photons_read", wide(kStatRead));
    ctx.count("photons_rejected", wide(kStatRejected));
    ctx.count("overflows", double(dropped));
    ctx.count("bytes_tile_bounds", double(bounds_.size()));
    ctx.count("bytes_photon_lists",
              double(lists_.size() + counts_.size() + offsets_.size() + cursors_.size()));
    ctx.count("bytes_photons", double(uint64_t(photon_count) * sizeof(pb::trace::PhotonRecord)));
    if (dropped > 0)
      ctx.warn(fmt::format(
          "tiled: per-tile photon lists overflowed: {} entries wanted, max_list_entries = {}; "
          "{} entries dropped (indirect light is underestimated in this frame)",
          entries, capacity_, dropped));
  }

  uint32_t paths_ = 0, tile_size_ = 32, capacity_ = 0, max_bounces_ = 4;
  float radius_ = 0;
  uint32_t width_ = 0, height_ = 0, tiles_x_ = 0, tiles_y_ = 0, tile_count_ = 0;
  pb::trace::PhotonBatch batch_;
  Buffer photons_, bounds_, counts_, offsets_, cursors_, lists_, stats_;
  pb::gpu::Image indirect_;
  pb::gpu::Pipeline bounds_pipeline_, count_pipeline_, scan_pipeline_, insert_pipeline_,
      estimate_pipeline_;
};

}  // namespace

PB_EXPORT_TECHNIQUE(
    Tiled, "tiled", "indirect",
    "Paper I's tiled photon splatting (Mara et al. 2013): 32x32 tiles with depth bounds, "
    "per-tile photon lists, constant-kernel radiance estimate",
    kParams)
