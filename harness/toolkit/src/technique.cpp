// The shared parts of a photon technique (photonbench/toolkit/technique.h).
#include "photonbench/toolkit/technique.h"

#include <fmt/format.h>

#include <algorithm>

#include "photonbench/error.h"

namespace pb::toolkit {

PhotonParams PhotonParams::read(const Params& params) { return kPhotonParams.read(params); }

trace::TraceSettings PhotonParams::trace_settings() const {
  trace::TraceSettings settings;
  settings.paths = paths;
  settings.max_bounces = max_bounces;
  settings.store = trace::kIndirectPhotons | trace::kCausticIndirectPhotons;
  if (store_first_hit) settings.store |= trace::kDirectPhotons;
  return settings;
}

void configure_direct_light(Context& ctx, const Params& params) {
  ctx.shared().configure_direct_light(kDirectLightParams.read(params));
}

void configure_shadows(Context& ctx, uint32_t map_size) {
  ctx.shared().configure_shadows(map_size, float(kDefaultShadowRelativeBias),
                                 float(kDefaultShadowNormalOffsetM));
}

void check_storage_range(const gpu::Device& gpu, uint64_t bytes, std::string_view what) {
  const uint64_t limit = gpu.limits().max_storage_buffer_range;
  if (bytes > limit)
    throw InputError(fmt::format(
        "{} needs a storage buffer of {} bytes, more than the device's maxStorageBufferRange ({} "
        "bytes)",
        what, bytes, limit));
}

uint32_t list_slices(uint64_t longest) {
  return std::max<uint32_t>(1, uint32_t((longest + PB_LIST_SLICE - 1) / PB_LIST_SLICE));
}

void dispatch_slices(vk::CommandBuffer cmd, uint64_t longest,
                     const std::function<void(uint32_t first)>& dispatch) {
  const uint32_t slices = list_slices(longest);
  for (uint32_t slice = 0; slice < slices; ++slice) {
    if (slice > 0) gpu::full_barrier(cmd);
    dispatch(slice * PB_LIST_SLICE);
  }
}

std::array<gpu::Resource, 3> gbuffer_resources(const GBuffer& gbuffer) {
  return {gbuffer.position, gbuffer.normal, gbuffer.albedo};
}

gpu::Buffer storage_buffer(gpu::Device& gpu, std::string name, uint64_t bytes, gpu::Memory memory) {
  using U = vk::BufferUsageFlagBits;
  return gpu.create_buffer(std::move(name), std::max<uint64_t>(bytes, 16),
                           U::eStorageBuffer | U::eTransferDst | U::eTransferSrc, memory);
}

void render_photon_frame(Context& ctx, const PhotonParams& photon, trace::PhotonBatch& batch,
                         gpu::Buffer& photons, std::string_view name, Splatter& splatter) {
  trace_and_upload_photons(ctx, photon.trace_settings(), batch, photons,
                           std::string(name) + "/photons");
  PhotonSet set{&photons, batch.photons};
  ctx.shared().gbuffer();
  ctx.shared().direct_light();
  const gpu::Image& indirect = splatter.render(ctx, set);
  gpu::full_barrier(ctx.cmd());
  ctx.shared().shade(&indirect);
  // The counters live on the GPU: wait for the frame's work (flush makes them host-visible).
  ctx.flush();
  splatter.report(ctx, set);
  pb::count(ctx, kBytesPhotonsCounter, double(uint64_t(set.count()) * sizeof(trace::PhotonRecord)));
}

}  // namespace pb::toolkit
