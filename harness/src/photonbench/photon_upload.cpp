// trace_and_upload_photons and trace_and_upload_camera_paths (photonbench/context.h): the two
// passes every photon technique, and every technique that gathers at camera paths, starts with.
#include <algorithm>
#include <cstring>
#include <string>

#include "photonbench/context.h"

namespace pb {

namespace {

// Copies `count` records of `record_bytes` into `buffer`, made or grown as needed: grown with a
// quarter to spare, so a count that drifts with the animation does not reallocate every frame.
void upload_records(Context& ctx, const void* records, uint32_t count, size_t record_bytes,
                    gpu::Buffer& buffer, std::string_view buffer_name) {
  const uint64_t bytes = uint64_t(std::max<uint32_t>(count, 1)) * record_bytes;
  if (!buffer || buffer.size() < bytes)
    buffer =
        ctx.gpu().create_buffer(std::string(buffer_name), bytes + bytes / 4,
                                vk::BufferUsageFlagBits::eStorageBuffer, gpu::Memory::host_visible);
  if (count) std::memcpy(buffer.mapped(), records, count * record_bytes);
}

}  // namespace

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
  upload_records(ctx, batch.photons.data(), count, sizeof(trace::PhotonRecord), photons,
                 buffer_name);
  return count;
}

uint32_t trace_and_upload_camera_paths(Context& ctx, const trace::CameraPathSettings& settings,
                                       trace::CameraPathBatch& batch, gpu::Buffer& paths,
                                       std::string_view buffer_name) {
  {
    auto scope = ctx.pass("camera-paths");
    ctx.camera_paths(settings, batch);
  }
  auto scope = ctx.pass("camera-path-upload");
  const uint32_t count = uint32_t(batch.paths.size());
  upload_records(ctx, batch.paths.data(), count, sizeof(trace::CameraPathRecord), paths,
                 buffer_name);
  return count;
}

}  // namespace pb
