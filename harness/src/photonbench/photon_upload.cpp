// trace_and_upload_photons (photonbench/context.h): the two passes every photon technique starts
// with.
#include <algorithm>
#include <cstring>
#include <string>

#include "photonbench/context.h"

namespace pb {

uint32_t trace_and_upload_photons(Context& ctx, const trace::TraceSettings& settings,
                                  trace::PhotonBatch& batch, gpu::Buffer& photons,
                                  std::string_view buffer_name) {
  uint32_t count = 0;
  {
    auto scope = ctx.pass("photon-trace");
    ctx.photon_tracer().trace(settings, batch);
    count = uint32_t(batch.photons.size());
    ctx.count({"photons_stored", CounterKind::size, "photons"}, count);
  }
  auto scope = ctx.pass("photon-upload");
  const uint64_t bytes = uint64_t(std::max<uint32_t>(count, 1)) * sizeof(trace::PhotonRecord);
  // Grown with a quarter to spare, so a photon count that drifts with the animation does not
  // reallocate every frame.
  if (!photons || photons.size() < bytes)
    photons =
        ctx.gpu().create_buffer(std::string(buffer_name), bytes + bytes / 4,
                                vk::BufferUsageFlagBits::eStorageBuffer, gpu::Memory::host_visible);
  if (count)
    std::memcpy(photons.mapped(), batch.photons.data(), count * sizeof(trace::PhotonRecord));
  return count;
}

}  // namespace pb
