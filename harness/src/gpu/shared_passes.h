// The scene on the GPU and the passes every technique shares: G-buffer (rasterised), shadow maps,
// direct light and final shading. Owned by the runner for one cell; handed to the technique as
// pb::SharedPasses through the context.
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "photonbench/context.h"
#include "photonbench/plugin.h"
#include "scene/scene.h"
#include "scene/world_triangles.h"
#include "trace/embree_scene.h"
#include "trace/nee.h"

namespace pb::gpu {

struct SharedPassOptions {
  uint32_t shadow_map_size = kDefaultShadowMapSize;  // texels per tile side
  float shadow_relative_bias = float(kDefaultShadowRelativeBias);
  float shadow_normal_offset = float(kDefaultShadowNormalOffsetM);
};

// What the many-light direct light (`direct_light: nee`) needs of the cell around the passes: a
// mid-frame flush (the G-buffer is read back before the CPU traces), the World's Embree scene (the
// shadow rays' substrate, shared with the photon tracer), the frame's counters and the seed axis'
// scramble.
struct HostServices {
  std::function<void()> flush;
  std::function<const trace::EmbreeScene&()> embree;
  std::function<void(const Counter&, double)> count;
  std::function<uint64_t()> seed;
};

class ScenePasses : public SharedPasses {
 public:
  // The counters direct_light() emits with `direct_light: nee`, declared by the harness for every
  // technique.
  static const std::array<pb_counter_spec, 7> kCounters;

  // `recorder` opens pass scopes; `cmd` returns the frame's current command buffer.
  ScenePasses(Device& device, const scene::Scene& scene, uint32_t width, uint32_t height,
              const SharedPassOptions& options, PassRecorder& recorder,
              std::function<vk::CommandBuffer()> cmd);

  // Uploads this frame's camera, lights, shadow views and moved or deformed geometry (the scene's
  // triangle records too, once a technique has asked for them).
  void update(const scene::FrameState& state);
  CameraView camera_view() const { return camera_; }
  const Image& output() const { return final_; }
  // The indirect radiance the technique handed to shade() this frame (null if none): its estimate
  // of its own path class alone, which the harness scores against that class's reference.
  const Image* indirect_estimate() const { return indirect_estimate_; }

  void gbuffer() override;
  void direct_light() override;
  void shade(const Image* indirect_radiance) override;
  void configure_shadows(uint32_t map_size, float relative_bias, float normal_offset_m) override;
  void configure_direct_light(const DirectLightSettings& settings) override;
  void attach_host(HostServices host) { host_ = std::move(host); }
  GBuffer gbuffer_images() const override { return {&position_, &normal_, &albedo_, &depth_}; }
  const Image& direct_image() const override { return direct_; }
  const Buffer& frame_buffer() const override { return frame_; }
  const Buffer& material_buffer() const override { return materials_; }
  const Buffer& light_buffer() const override { return lights_; }
  SceneTriangles scene_triangles() override;
  void draw_scene(const SceneTarget& target,
                  std::optional<glm::mat4> view_projection = std::nullopt) override;
  const Buffer& tile_buffer() const { return tiles_; }
  // Empty until the shadow-mapped direct light first needs it, and with `direct_light: nee`.
  const Image& atlas() const { return shadow_atlas_; }

 private:
  struct GpuMesh {
    Buffer vertices;  // interleaved position, normal (6 floats)
    Buffer indices;
    uint32_t index_count = 0;
  };
  void upload_mesh(GpuMesh& gpu_mesh, const scene::Mesh& mesh, const std::string& name);
  void shadow_maps();
  // direct_light() with `direct_light: nee`: read back the G-buffer, estimate on the CPU, upload.
  void nee_direct_light();
  // This frame's emissive triangles into emissive_; their objects' shadow cubes go onto `tiles`.
  void upload_emissive_triangles(const scene::FrameState& state, float shadow_far,
                                 std::vector<glm::mat4>& tiles);
  template <class Bind>
  void draw_object(vk::CommandBuffer cmd, size_t i, const Bind& bind, uint32_t index);
  // The shadow-mapped direct light's atlas: six tiles per light and per emissive object
  // (directional lights one), tiles_per_row_ to a row.
  vk::Extent2D shadow_atlas_extent() const;
  // Makes the atlas at shadow_atlas_extent() unless it is already that size; an atlas beyond the
  // device's image limit throws InputError naming the limit.
  void ensure_shadow_atlas();
  // Rewrites the triangle records of what moved or deformed (`deformed`: as
  // WorldTriangles::update).
  void refresh_triangles(const scene::FrameState& state, std::span<const scene::Mesh> deformed);

  Device& device_;
  const scene::Scene& scene_;
  uint32_t width_, height_;
  SharedPassOptions options_;
  PassRecorder& recorder_;
  std::function<vk::CommandBuffer()> cmd_;
  std::vector<GpuMesh> meshes_;
  std::vector<glm::mat4> object_to_world_;
  CameraView camera_{};
  uint32_t tiles_per_row_ = 6, tile_count_ = 0;
  std::vector<int> tile_object_;  // per shadow tile: the emissive object it belongs to, or -1
  std::vector<uint32_t> emissive_objects_;  // objects with an emissive material, in scene order
  uint32_t emissive_count_ = 0;             // emissive triangles this frame
  Buffer frame_, materials_, lights_, tiles_, emissive_;
  Image position_, normal_, albedo_, depth_, shadow_atlas_, direct_, final_;
  const Image* indirect_estimate_ = nullptr;
  Pipeline gbuffer_pipeline_, shadow_pipeline_, direct_pipeline_, shade_pipeline_;
  // The scene's triangles and draw_scene: made on first use, so a technique that never asks pays
  // nothing for them.
  scene::FrameState state_;
  std::unique_ptr<scene::WorldTriangles> world_triangles_;
  Buffer scene_vertices_, scene_triangles_;
  uint32_t triangles_changed_frame_ = 0;
  std::optional<Pipeline> draw_scene_pipeline_;
  // The many-light direct light.
  DirectLightSettings direct_settings_;
  HostServices host_;
  std::unique_ptr<trace::NextEventEstimator> nee_;
  bool nee_lights_changed_ = true;  // the light set must be rebuilt before the next estimate
  Buffer direct_upload_;
  std::vector<float> gbuffer_position_, gbuffer_normal_, nee_radiance_;
};

}  // namespace pb::gpu
