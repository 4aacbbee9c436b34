// TiledSplat (photonbench/toolkit/tiled_splat.h).
#include "photonbench/toolkit/tiled_splat.h"

#include <fmt/format.h>

#include <string>

#include "photonbench/error.h"
#include "toolkit_shaders.h"

namespace pb::toolkit {

namespace {

// Mirrors the push block of harness/shaders/toolkit/tiled/tiled_common.glsl.
struct TiledPush {
  glm::mat4 view_projection;
  glm::vec4 depth_plane;
  uint32_t width, height, tiles_x, tiles_y;
  uint32_t photon_count, tile_size, tile_count, mode;
  float radius, estimate_radius;
  uint32_t list_first = 0, pad0 = 0;
};
static_assert(sizeof(TiledPush) == 128);

constexpr uint32_t kTiledStatRead = 0, kTiledStatRejected = 2, kTiledStatWords = 4;
constexpr uint32_t kTiledModeCount = 0, kTiledModeInsert = 1;

}  // namespace

std::string TiledSplat::check(const Params& params) {
  const uint32_t tile_size = kParams.read(params).tile_size;
  if (tile_size % 8 != 0)
    return fmt::format(
        "tile_size: {} is not a multiple of 8 (the 8x8 work groups of tile-bounds must lie in one "
        "tile)",
        tile_size);
  return "";
}

void TiledSplat::setup(Context& ctx, const Params& params, const PhotonParams& photon) {
  radius_ = photon.radius;
  options_ = kParams.read(params);
  const uint32_t capacity = options_.max_list_entries;
  auto& gpu = ctx.gpu();
  check_storage_range(gpu, uint64_t(capacity) * 4,
                      fmt::format("tiled: max_list_entries = {} (4 bytes each)", capacity));
  scan_.setup(gpu);
  lists_.setup(gpu, capacity, "tiled");
  stats_ = storage_buffer(gpu, "tiled/stats", kTiledStatWords * 4, gpu::Memory::host_visible);

  auto B = gpu::Binding::storage_buffer;
  auto I = gpu::Binding::storage_image;
  std::vector<gpu::Binding> bindings(PhotonLists::kBindingCount + 3, B);
  bindings.insert(bindings.end(), {I, I, I, I});
  constexpr uint32_t kPush = sizeof(TiledPush);
  bounds_pipeline_ =
      gpu.create_compute_pipeline("tile-bounds", ktiled_bounds_comp_spv, bindings, kPush);
  splat_pipeline_ = gpu.create_compute_pipeline("splat", ktiled_splat_comp_spv, bindings, kPush);
  estimate_pipeline_ =
      gpu.create_compute_pipeline("radiance-estimate", ktiled_estimate_comp_spv, bindings, kPush);
}

void TiledSplat::ensure_resources(Context& ctx) {
  const auto& frame = ctx.frame();
  if (indirect_.extent().width == frame.width && indirect_.extent().height == frame.height) return;
  auto& gpu = ctx.gpu();
  width_ = frame.width;
  height_ = frame.height;
  tiles_x_ = gpu::groups_for(width_, options_.tile_size);
  tiles_y_ = gpu::groups_for(height_, options_.tile_size);
  tile_count_ = tiles_x_ * tiles_y_;
  bounds_ = storage_buffer(gpu, "tiled/tile-bounds", uint64_t(tile_count_) * 8);
  lists_.resize(gpu, scan_, tile_count_);
  indirect_ = gpu.create_image("tiled/indirect", {width_, height_}, vk::Format::eR32G32B32A32Sfloat,
                               vk::ImageUsageFlagBits::eStorage);
}

const gpu::Image& TiledSplat::render(Context& ctx, const PhotonSet& photons) {
  ensure_resources(ctx);
  const auto& frame = ctx.frame();
  TiledPush push{};
  push.view_projection = frame.camera.view_projection;
  // View depth along the viewing axis: -(view * p).z for a right-handed view matrix (column-major).
  const glm::mat4& v = frame.camera.view;
  push.depth_plane = -glm::vec4(v[0][2], v[1][2], v[2][2], v[3][2]);
  push.width = width_;
  push.height = height_;
  push.tiles_x = tiles_x_;
  push.tiles_y = tiles_y_;
  push.photon_count = photons.count();
  push.tile_size = options_.tile_size;
  push.tile_count = tile_count_;
  push.radius = radius_;
  push.estimate_radius = radius_;

  auto gbuf = ctx.shared().gbuffer_images();
  std::vector<gpu::Resource> resources;
  lists_.append_bindings(resources);
  resources.insert(resources.end(), {photons.buffer, &bounds_, &stats_});
  auto g = gbuffer_resources(gbuf);
  resources.insert(resources.end(), g.begin(), g.end());
  resources.push_back(&indirect_);
  const uint32_t photon_groups = std::max<uint32_t>(1, gpu::groups_for(photons.count(), 64));

  // ctx.cmd() is fetched anew in every pass: with fenced timing (lavapipe) a pass scope submits and
  // continues in a fresh command buffer.
  {
    auto scope = ctx.pass("tile-bounds");
    auto cmd = ctx.cmd();
    const uint32_t n = tile_count_ * 4;
    cmd.fillBuffer(bounds_.handle(), 0, n, 0x7f800000u);  // zmin = +inf
    cmd.fillBuffer(bounds_.handle(), n, n, 0u);           // zmax = 0
    cmd.fillBuffer(stats_.handle(), 0, VK_WHOLE_SIZE, 0u);
    lists_.clear(cmd);
    gpu::full_barrier(cmd);
    bounds_pipeline_.bind(cmd, resources, push);
    cmd.dispatch(gpu::groups_for(width_, 8), gpu::groups_for(height_, 8), 1);
  }
  gpu::full_barrier(ctx.cmd());
  {
    auto splat = ctx.pass("splat");
    lists_.record_runs(ctx, scan_, [&](vk::CommandBuffer cmd, bool insert) {
      push.mode = insert ? kTiledModeInsert : kTiledModeCount;
      push.radius = insert ? radius_ * options_.insert_radius_scale : radius_;
      splat_pipeline_.bind(cmd, resources, push);
      cmd.dispatch(photon_groups, 1, 1);
    });
  }
  gpu::full_barrier(ctx.cmd());
  {
    auto scope = ctx.pass("radiance-estimate");
    auto cmd = ctx.cmd();
    // A tile's list holds each photon at most once, so the photon count bounds its length.
    dispatch_slices(cmd, photons.count(), [&](uint32_t first) {
      push.list_first = first;
      estimate_pipeline_.bind(cmd, resources, push);
      cmd.dispatch(gpu::groups_for(width_, 8), gpu::groups_for(height_, 8), 1);
    });
  }
  return indirect_;
}

void TiledSplat::report(Context& ctx, const PhotonSet&) {
  auto s = stats_.view<uint32_t>();
  auto wide = [&](uint32_t at) { return double(uint64_t(s[at]) | (uint64_t(s[at + 1]) << 32)); };
  lists_.report(ctx, "tiled: per-tile photon lists", "max_list_entries");
  pb::count(ctx, kPhotonsReadCounter, wide(kTiledStatRead));
  pb::count(ctx, kPhotonsRejectedCounter, wide(kTiledStatRejected));
  pb::count(ctx, kBytesTileBoundsCounter, double(bounds_.size()));
  pb::count(ctx, kBytesPhotonListsCounter, double(lists_.bytes()));
}

}  // namespace pb::toolkit
