#include "gpu/shared_passes.h"

#include <fmt/format.h>

#include <glm/gtc/matrix_transform.hpp>

#include "photonbench/error.h"
#include "photonbench/scene_layout.h"
#include "scene/emissive_triangles.h"
#include "shared_shaders.h"

namespace pb::gpu {

static_assert(sizeof(layout::GpuMaterial) == 48);
static_assert(sizeof(layout::GpuLight) == 80);
// The shaders read the light type as pb::scene::LightType's value.
static_assert(PB_LIGHT_QUAD == int(scene::LightType::quad) &&
              PB_LIGHT_DISC == int(scene::LightType::disc));
static_assert(sizeof(layout::GpuFrame) == 176);
static_assert(sizeof(layout::GpuSceneVertex) == 32 && sizeof(layout::GpuSceneTriangle) == 48);

namespace {

constexpr vk::Format kColor = vk::Format::eR32G32B32A32Sfloat;
constexpr vk::Format kDepth = vk::Format::eD32Sfloat;
constexpr float kShadowNear = 0.05f;
constexpr uint32_t kGroup = 8;

struct DrawPush {
  glm::mat4 model;
  uint32_t index;  // material (G-buffer) or tile (shadow)
};

// direct.comp's push constants.
struct DirectPush {
  float relative_bias, normal_offset, near_plane, far_plane;
  uint32_t emissive_count;
};

// One emissive triangle as direct.comp reads it (its EmissiveTriangle block, std430).
struct GpuEmissiveTriangle {
  glm::vec4 a_first_tile;   // xyz: vertex 0; w: the first of its object's 6 shadow tiles
  glm::vec4 b, c;           // vertices 1 and 2, wound to face the emitting side
  glm::vec4 radiance;       // rgb: W/(m^2 sr)
  glm::vec4 shadow_origin;  // xyz: where its object's shadow cube sits
};
static_assert(sizeof(GpuEmissiveTriangle) == 80);

layout::GpuMaterial to_gpu(const scene::Material& m) {
  return {glm::vec4(m.albedo, float(int(m.type))), glm::vec4(m.emission, m.roughness),
          glm::vec4(m.specular, m.ior)};
}

struct DrawScenePush {
  glm::mat4 view_projection;
  glm::vec4 eye;  // w = 1: a position; w = 0: the direction towards an eye at infinity
};

// Where the viewer of `view_projection` is: the point that projects to clip (0, 0, z, 0), found as
// inverse(view_projection) (0, 0, 1, 0); with w = 0 (an orthographic view) that is the direction
// of increasing depth, and the viewer lies the other way.
glm::vec4 eye_of(const glm::mat4& view_projection) {
  glm::vec4 h = glm::inverse(view_projection) * glm::vec4(0, 0, 1, 0);
  if (std::abs(h.w) > 1e-6f * glm::length(glm::vec3(h))) return glm::vec4(glm::vec3(h) / h.w, 1.f);
  return glm::vec4(-glm::normalize(glm::vec3(h)), 0.f);
}

// Begins dynamic rendering into `colors` (cleared to `clears`) and `depth` (cleared to 1) within
// `area`, with the viewport and scissor on `area`: the raster passes' common start.
void begin_raster(const Device& device, vk::CommandBuffer cmd, std::span<const Image* const> colors,
                  std::span<const vk::ClearColorValue> clears, const Image& depth,
                  vk::Rect2D area) {
  std::vector<vk::RenderingAttachmentInfo> attachments;
  for (size_t i = 0; i < colors.size(); ++i)
    attachments.push_back(vk::RenderingAttachmentInfo{colors[i]->view(),
                                                      vk::ImageLayout::eGeneral,
                                                      {},
                                                      {},
                                                      {},
                                                      vk::AttachmentLoadOp::eClear,
                                                      vk::AttachmentStoreOp::eStore,
                                                      clears[i]});
  vk::RenderingAttachmentInfo depth_attachment{depth.view(),
                                               vk::ImageLayout::eGeneral,
                                               {},
                                               {},
                                               {},
                                               vk::AttachmentLoadOp::eClear,
                                               vk::AttachmentStoreOp::eStore,
                                               vk::ClearDepthStencilValue(1.f, 0)};
  device.begin_rendering(cmd, vk::RenderingInfo{{}, area, 1, 0, attachments, &depth_attachment});
  // Vulkan's y points down in clip space; Camera::projection already flips, so the viewport is
  // plain.
  cmd.setViewport(0, vk::Viewport{float(area.offset.x), float(area.offset.y),
                                  float(area.extent.width), float(area.extent.height), 0, 1});
  cmd.setScissor(0, area);
}

// The 6 cube-face views around `p`, in the order the direct-light shader picks them (+x -x +y -y +z
// -z).
void cube_views(glm::vec3 p, float far_plane, std::vector<glm::mat4>& out) {
  const glm::vec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  glm::mat4 projection = glm::perspectiveRH_ZO(glm::radians(90.f), 1.f, kShadowNear, far_plane);
  for (int face = 0; face < 6; ++face) {
    glm::vec3 up = face == 2 || face == 3 ? glm::vec3(0, 0, 1) : glm::vec3(0, 1, 0);
    out.push_back(projection * glm::lookAtRH(p, p + axes[face], up));
  }
}

// Whether the lights the estimator samples differ between two frames: a scene light moved, turned
// or changed power, or an emissive object moved or deformed.
bool lights_differ(const scene::Scene& scene, const scene::FrameState& a,
                   const scene::FrameState& b) {
  if (a.lights.size() != b.lights.size()) return true;
  for (size_t i = 0; i < a.lights.size(); ++i) {
    const scene::Light &x = a.lights[i], &y = b.lights[i];
    if (x.position != y.position || x.radiant != y.radiant || x.direction != y.direction ||
        x.edge_u != y.edge_u || x.edge_v != y.edge_v)
      return true;
  }
  for (size_t i = 0; i < scene.objects.size() && i < a.object_to_world.size(); ++i)
    if (scene::is_emissive(scene, i) && a.object_to_world[i] != b.object_to_world[i]) return true;
  for (uint32_t i : b.deformed_objects)
    if (scene::is_emissive(scene, i)) return true;
  return false;
}

}  // namespace

// clang-format off
const std::array<pb_counter_spec, 7> ScenePasses::kCounters = {{
    {"nee_lights", PB_COUNTER_SIZE, "lights", "lights the next-event estimator samples"},
    {"nee_culled", PB_COUNTER_SIZE, "triangles", "emissive triangles of zero flux left out"},
    {"light_bvh_nodes", PB_COUNTER_SIZE, "nodes", "nodes of the light BVH"},
    {"light_bvh_bytes", PB_COUNTER_SIZE, "bytes", "the light BVH: nodes, order, lights"},
    {"nee_nodes_per_sample", PB_COUNTER_RATIO, "nodes", "light-BVH nodes per light sample"},
    {"nee_shadow_rays", PB_COUNTER_WORK, "rays", "shadow rays traced"},
    {"nee_occluded_share", PB_COUNTER_RATIO, "fraction", "of the shadow rays, the blocked share"},
}};
// clang-format on

ScenePasses::ScenePasses(Device& device, const scene::Scene& scene, uint32_t width, uint32_t height,
                         const SharedPassOptions& options, PassRecorder& recorder,
                         std::function<vk::CommandBuffer()> cmd)
    : device_(device),
      scene_(scene),
      width_(width),
      height_(height),
      options_(options),
      recorder_(recorder),
      cmd_(std::move(cmd)),
      state_(scene.at(0)) {
  using U = vk::BufferUsageFlagBits;
  using I = vk::ImageUsageFlagBits;
  meshes_.resize(scene.objects.size());
  for (size_t i = 0; i < scene.objects.size(); ++i)
    upload_mesh(meshes_[i], scene.objects[i].mesh, "world/" + scene.objects[i].name);

  std::vector<layout::GpuMaterial> materials;
  for (const auto& m : scene.materials) materials.push_back(to_gpu(m));
  if (materials.empty()) materials.push_back(to_gpu(scene::Material{}));
  materials_ =
      device.create_buffer("world/materials", materials.size() * sizeof(layout::GpuMaterial),
                           U::eStorageBuffer, Memory::device_local);
  device.upload(materials_, materials.data(), materials.size() * sizeof(layout::GpuMaterial));

  for (const auto& track : scene.lights)
    tile_count_ += track.light.type == scene::LightType::directional ? 1 : 6;
  tile_object_.assign(tile_count_, -1);
  // Each emissive object gets a shadow cube of its own, after the lights' tiles; the object itself
  // is left out of its own cube (it would hide everything from a cube inside a closed emitter).
  for (size_t i = 0; i < scene.objects.size(); ++i)
    if (scene::is_emissive(scene, i)) {
      emissive_objects_.push_back(uint32_t(i));
      tile_object_.insert(tile_object_.end(), 6, int(i));
      tile_count_ += 6;
    }
  size_t light_count = std::max<size_t>(scene.lights.size(), 1);
  frame_ = device.create_buffer("world/frame", sizeof(layout::GpuFrame), U::eStorageBuffer,
                                Memory::host_visible);
  lights_ = device.create_buffer("world/lights", light_count * sizeof(layout::GpuLight),
                                 U::eStorageBuffer, Memory::host_visible);
  emissive_ = device.create_buffer("world/emissive-triangles", sizeof(GpuEmissiveTriangle),
                                   U::eStorageBuffer, Memory::host_visible);
  tiles_ = device.create_buffer("world/shadow-views",
                                std::max<uint32_t>(tile_count_, 1) * sizeof(glm::mat4),
                                U::eStorageBuffer, Memory::host_visible);

  vk::Extent2D extent{width, height};
  auto storage = I::eStorage | I::eColorAttachment;
  position_ = device.create_image("gbuffer/position", extent, kColor, storage);
  normal_ = device.create_image("gbuffer/normal", extent, kColor, storage);
  albedo_ = device.create_image("gbuffer/albedo", extent, kColor, storage);
  depth_ = device.create_image("gbuffer/depth", extent, kDepth,
                               I::eDepthStencilAttachment | I::eSampled);
  direct_ = device.create_image("direct/radiance", extent, kColor, I::eStorage);
  final_ = device.create_image("output/radiance", extent, kColor, I::eStorage);

  GraphicsPipelineDesc gbuffer{"gbuffer",
                               kgbuffer_vert_spv,
                               kgbuffer_frag_spv,
                               {Binding::storage_buffer, Binding::storage_buffer},
                               sizeof(DrawPush),
                               6 * sizeof(float),
                               {vk::Format::eR32G32B32Sfloat, vk::Format::eR32G32B32Sfloat},
                               {kColor, kColor, kColor},
                               kDepth};
  gbuffer_pipeline_ = device.create_graphics_pipeline(gbuffer);
  GraphicsPipelineDesc shadow{"shadow-maps",
                              kshadow_vert_spv,
                              {},
                              {Binding::storage_buffer},
                              sizeof(DrawPush),
                              6 * sizeof(float),
                              {vk::Format::eR32G32B32Sfloat, vk::Format::eR32G32B32Sfloat},
                              {},
                              kDepth};
  shadow_pipeline_ = device.create_graphics_pipeline(shadow);
  using B = Binding;
  direct_pipeline_ = device.create_compute_pipeline(
      "direct-light", kdirect_comp_spv,
      {B::storage_buffer, B::storage_buffer, B::storage_buffer, B::storage_buffer, B::storage_image,
       B::storage_image, B::sampled_image, B::storage_image, B::storage_buffer},
      sizeof(DirectPush));
  shade_pipeline_ = device.create_compute_pipeline(
      "shade", kshade_comp_spv,
      {B::storage_buffer, B::storage_buffer, B::storage_image, B::storage_image, B::storage_image,
       B::storage_image, B::storage_image},
      sizeof(uint32_t));
}

vk::Extent2D ScenePasses::shadow_atlas_extent() const {
  uint32_t size = options_.shadow_map_size;
  uint32_t rows = std::max<uint32_t>((tile_count_ + tiles_per_row_ - 1) / tiles_per_row_, 1);
  return {size * tiles_per_row_, size * rows};
}

void ScenePasses::ensure_shadow_atlas() {
  const vk::Extent2D extent = shadow_atlas_extent();
  if (shadow_atlas_.bytes() != 0 && shadow_atlas_.extent() == extent) return;
  shadow_atlas_ = Image();  // release the old atlas before making the new one
  try {
    shadow_atlas_ = device_.create_image(
        "shadow/atlas", extent, kDepth,
        vk::ImageUsageFlagBits::eDepthStencilAttachment | vk::ImageUsageFlagBits::eSampled);
  } catch (const Error& e) {
    // A cell the shadow-mapped direct light cannot hold is refused, not degraded behind the
    // user's back: the many-light direct light needs no atlas.
    throw InputError(fmt::format(
        "direct_light: shadow_maps: {} lights and {} emissive objects need {} shadow tiles of {} "
        "texels, {} to a row: {}; use direct_light: nee (no shadow atlas) or smaller shadow maps",
        scene_.lights.size(), emissive_objects_.size(), tile_count_, options_.shadow_map_size,
        tiles_per_row_, e.what()));
  }
}

void ScenePasses::configure_shadows(uint32_t map_size, float relative_bias, float normal_offset_m) {
  if (map_size < 16 || map_size > 4096)
    throw Error(fmt::format("shadow map size {} outside [16, 4096]", map_size));
  options_.shadow_relative_bias = relative_bias;
  options_.shadow_normal_offset = normal_offset_m;
  options_.shadow_map_size = map_size;
  // A technique that configured the shadow-mapped direct light first resizes its atlas here, in
  // set-up; otherwise configure_direct_light makes it (or the first shadow_maps(), for a technique
  // that calls neither).
  if (shadow_atlas_.bytes() != 0) ensure_shadow_atlas();
}

void ScenePasses::configure_direct_light(const DirectLightSettings& settings) {
  if (settings.light_samples < 1 || settings.light_samples > 64)
    throw InputError(fmt::format("light_samples: {} outside [1, 64]", settings.light_samples));
  direct_settings_ = settings;
  nee_.reset();
  nee_lights_changed_ = true;
  // The atlas exists only for the shadow-mapped direct light, made (or refused) here in set-up.
  if (settings.method == DirectLightMethod::shadow_maps)
    ensure_shadow_atlas();
  else
    shadow_atlas_ = Image();
}

void ScenePasses::upload_mesh(GpuMesh& gpu_mesh, const scene::Mesh& mesh, const std::string& name) {
  using U = vk::BufferUsageFlagBits;
  std::vector<float> interleaved;
  interleaved.reserve(mesh.positions.size() * 6);
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    glm::vec3 n = v < mesh.normals.size() ? mesh.normals[v] : glm::vec3(0, 1, 0);
    interleaved.insert(interleaved.end(), {mesh.positions[v].x, mesh.positions[v].y,
                                           mesh.positions[v].z, n.x, n.y, n.z});
  }
  size_t vertex_bytes = interleaved.size() * sizeof(float);
  size_t index_bytes = mesh.triangles.size() * sizeof(glm::uvec3);
  if (!gpu_mesh.vertices || gpu_mesh.vertices.size() < vertex_bytes)
    gpu_mesh.vertices = device_.create_buffer(name + "/vertices", vertex_bytes, U::eVertexBuffer,
                                              Memory::host_visible);
  if (!gpu_mesh.indices || gpu_mesh.indices.size() < index_bytes)
    gpu_mesh.indices = device_.create_buffer(name + "/indices", index_bytes, U::eIndexBuffer,
                                             Memory::host_visible);
  device_.upload(gpu_mesh.vertices, interleaved.data(), vertex_bytes);
  device_.upload(gpu_mesh.indices, mesh.triangles.data(), index_bytes);
  gpu_mesh.index_count = uint32_t(mesh.triangles.size() * 3);
}

void ScenePasses::update(const scene::FrameState& state) {
  indirect_estimate_ = nullptr;  // a new frame: shade() has not run yet
  if (lights_differ(scene_, state_, state)) nee_lights_changed_ = true;
  object_to_world_ = state.object_to_world;
  state_ = state;
  // Deformed meshes (the pool's water) are re-tessellated and re-uploaded; rigid motion is a
  // matrix.
  std::vector<scene::Mesh> deformed;
  for (uint32_t i : state.deformed_objects) {
    deformed.push_back(scene_.mesh_at(i, state.time));
    upload_mesh(meshes_[i], deformed.back(), "world/" + scene_.objects[i].name);
  }
  if (world_triangles_) refresh_triangles(state, deformed);

  float aspect = float(width_) / float(height_);
  camera_.view = state.camera.view();
  camera_.projection = state.camera.projection(aspect);
  camera_.view_projection = camera_.projection * camera_.view;
  camera_.inverse_view_projection = glm::inverse(camera_.view_projection);
  camera_.position = state.camera.position;
  camera_.fov_y = state.camera.fov_y;

  auto [lo, hi] = scene_.bounds();
  glm::vec3 centre = 0.5f * (lo + hi);
  float radius = std::max(0.5f * glm::length(hi - lo), 1e-3f);
  float shadow_far = 4.f * radius + 1.f;

  // The light and tile buffers were sized for the scene's light tracks (one light each, its tiles
  // by its type): a frame state holding other lights would write past them.
  if (state.lights.size() > std::max<size_t>(scene_.lights.size(), 1))
    throw std::logic_error(fmt::format("frame state has {} lights, the scene's tracks {}",
                                       state.lights.size(), scene_.lights.size()));
  std::vector<glm::mat4> tiles;
  auto lights = std::span(static_cast<layout::GpuLight*>(lights_.mapped()), state.lights.size());
  for (size_t i = 0; i < state.lights.size(); ++i) {
    const scene::Light& light = state.lights[i];
    layout::GpuLight& g = lights[i];
    g.position_type = glm::vec4(light.position, float(int(light.type)));
    g.radiant = glm::vec4(light.radiant, 0.f);
    g.direction_cos_outer = glm::vec4(glm::normalize(light.direction), std::cos(light.spot_outer));
    g.edge_u_cos_inner = glm::vec4(light.edge_u, std::cos(light.spot_inner));
    g.edge_v_first_tile = glm::vec4(light.edge_v, float(tiles.size()));
    if (light.type == scene::LightType::directional) {
      glm::vec3 d = glm::normalize(light.direction);
      glm::vec3 up = std::abs(d.y) > 0.99f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
      glm::mat4 view = glm::lookAtRH(centre - d * 2.f * radius, centre, up);
      tiles.push_back(glm::orthoRH_ZO(-radius, radius, -radius, radius, 0.f, 4.f * radius) * view);
    } else {
      // A quad's shadow cube sits at its centre; a disc's position is its centre.
      glm::vec3 origin = light.type == scene::LightType::quad
                             ? light.position + 0.5f * (light.edge_u + light.edge_v)
                             : light.position;
      cube_views(origin, shadow_far, tiles);
    }
  }
  upload_emissive_triangles(state, shadow_far, tiles);
  if (tiles.size() > tile_count_)
    throw std::logic_error(
        fmt::format("{} shadow tiles this frame, {} allocated", tiles.size(), tile_count_));
  if (!tiles.empty()) std::memcpy(tiles_.mapped(), tiles.data(), tiles.size() * sizeof(glm::mat4));

  layout::GpuFrame frame{};
  frame.view_projection = camera_.view_projection;
  frame.inverse_view_projection = camera_.inverse_view_projection;
  frame.camera_position = glm::vec4(camera_.position, camera_.fov_y);
  frame.size_lights =
      glm::uvec4(width_, height_, uint32_t(state.lights.size()), options_.shadow_map_size);
  vk::Extent2D atlas = shadow_atlas_extent();
  frame.shadow_atlas = glm::uvec4(atlas.width, atlas.height, tiles_per_row_, tile_count_);
  std::memcpy(frame_.mapped(), &frame, sizeof(frame));
}

void ScenePasses::upload_emissive_triangles(const scene::FrameState& state, float shadow_far,
                                            std::vector<glm::mat4>& tiles) {
  std::vector<scene::EmissiveTriangle> triangles;
  if (!emissive_objects_.empty()) triangles = scene::emissive_triangles(scene_, state);
  std::vector<GpuEmissiveTriangle> gpu;
  gpu.reserve(triangles.size());
  size_t next = 0;
  for (uint32_t object : emissive_objects_) {
    // The shadow cube sits at the object's area-weighted centroid (an area light's shadows are
    // those of its centre, as for quad and disc lights: hard, a documented approximation).
    size_t first = next;
    glm::vec3 weighted{0.0f};
    float area = 0;
    for (; next < triangles.size() && triangles[next].object == object; ++next) {
      weighted += triangles[next].area * triangles[next].centroid();
      area += triangles[next].area;
    }
    glm::vec3 origin = area > 0 ? weighted / area : glm::vec3(state.object_to_world[object][3]);
    float first_tile = float(tiles.size());
    cube_views(origin, shadow_far, tiles);
    for (size_t t = first; t < next; ++t) {
      const scene::EmissiveTriangle& e = triangles[t];
      gpu.push_back({glm::vec4(e.p[0], first_tile), glm::vec4(e.p[1], 0.f), glm::vec4(e.p[2], 0.f),
                     glm::vec4(e.radiance, 0.f), glm::vec4(origin, 0.f)});
    }
  }
  emissive_count_ = uint32_t(gpu.size());
  size_t bytes = gpu.size() * sizeof(GpuEmissiveTriangle);
  if (bytes > emissive_.size())
    emissive_ =
        device_.create_buffer("world/emissive-triangles", bytes,
                              vk::BufferUsageFlagBits::eStorageBuffer, Memory::host_visible);
  if (bytes) std::memcpy(emissive_.mapped(), gpu.data(), bytes);
}

// One object's draw: `bind` binds the pass's pipeline with the push constants (object-to-world
// matrix and the pass's index: material for the G-buffer, atlas tile for shadows).
template <class Bind>
void ScenePasses::draw_object(vk::CommandBuffer cmd, size_t i, const Bind& bind, uint32_t index) {
  if (meshes_[i].index_count == 0) return;
  bind(DrawPush{object_to_world_[i], index});
  cmd.bindVertexBuffers(0, meshes_[i].vertices.handle(), vk::DeviceSize(0));
  cmd.bindIndexBuffer(meshes_[i].indices.handle(), 0, vk::IndexType::eUint32);
  cmd.drawIndexed(meshes_[i].index_count, 1, 0, 0, 0);
}

void ScenePasses::gbuffer() {
  auto scope = PassScope(&recorder_, recorder_.begin_pass("gbuffer"));
  vk::CommandBuffer cmd = cmd_();
  const Image* targets[3] = {&position_, &normal_, &albedo_};
  const vk::ClearColorValue clear(std::array<float, 4>{0, 0, 0, 0});
  const vk::ClearColorValue clears[3] = {clear, clear, clear};
  begin_raster(device_, cmd, targets, clears, depth_, vk::Rect2D{{0, 0}, {width_, height_}});
  for (size_t i = 0; i < meshes_.size(); ++i)
    draw_object(
        cmd, i,
        [&](const DrawPush& push) {
          gbuffer_pipeline_.bind(cmd, {&frame_, &materials_}, push);
        },
        scene_.objects[i].material);
  device_.end_rendering(cmd);
}

void ScenePasses::shadow_maps() {
  ensure_shadow_atlas();
  auto scope = PassScope(&recorder_, recorder_.begin_pass("shadow-maps"));
  vk::CommandBuffer cmd = cmd_();
  vk::Extent2D atlas = shadow_atlas_.extent();
  vk::RenderingAttachmentInfo depth{shadow_atlas_.view(),
                                    vk::ImageLayout::eGeneral,
                                    {},
                                    {},
                                    {},
                                    vk::AttachmentLoadOp::eClear,
                                    vk::AttachmentStoreOp::eStore,
                                    vk::ClearDepthStencilValue(1.f, 0)};
  // Built with setters: with no colour attachments, brace initialisation picks the (count, pointer)
  // constructor and would pass the depth attachment as a colour one.
  vk::RenderingInfo rendering;
  rendering.setRenderArea({{0, 0}, atlas}).setLayerCount(1).setPDepthAttachment(&depth);
  device_.begin_rendering(cmd, rendering);
  uint32_t size = options_.shadow_map_size;
  for (uint32_t tile = 0; tile < tile_count_; ++tile) {
    int32_t x = int32_t((tile % tiles_per_row_) * size),
            y = int32_t((tile / tiles_per_row_) * size);
    cmd.setViewport(0, vk::Viewport{float(x), float(y), float(size), float(size), 0, 1});
    cmd.setScissor(0, vk::Rect2D{{x, y}, {size, size}});
    for (size_t i = 0; i < meshes_.size(); ++i)
      if (tile_object_[tile] != int(i))
        draw_object(
            cmd, i, [&](const DrawPush& push) { shadow_pipeline_.bind(cmd, {&tiles_}, push); },
            tile);
  }
  device_.end_rendering(cmd);
}

void ScenePasses::direct_light() {
  auto scope = PassScope(&recorder_, recorder_.begin_pass("direct-light"));
  if (direct_settings_.method == DirectLightMethod::nee) {
    nee_direct_light();
    return;
  }
  shadow_maps();
  auto lighting = PassScope(&recorder_, recorder_.begin_pass("lighting"));
  vk::CommandBuffer cmd = cmd_();
  auto [lo, hi] = scene_.bounds();
  float far_plane = 4.f * std::max(0.5f * glm::length(hi - lo), 1e-3f) + 1.f;
  DirectPush push{options_.shadow_relative_bias, options_.shadow_normal_offset, kShadowNear,
                  far_plane, emissive_count_};
  direct_pipeline_.bind(cmd,
                        {&frame_, &materials_, &lights_, &tiles_, &position_, &normal_,
                         Sampled{&shadow_atlas_}, &direct_, &emissive_},
                        push);
  cmd.dispatch(groups_for(width_, kGroup), groups_for(height_, kGroup), 1);
}

void ScenePasses::nee_direct_light() {
  if (!host_.flush || !host_.embree)
    throw Error("direct_light: nee needs the cell's host services (ScenePasses::attach_host)");
  if (!nee_) {
    nee_ = std::make_unique<trace::NextEventEstimator>(direct_settings_, trace::LightBvhOptions{});
    auto build = PassScope(&recorder_, recorder_.begin_pass("light-bvh/build"));
    nee_->build(scene_, state_);
    nee_lights_changed_ = false;
  }
  if (nee_lights_changed_) {
    const bool refit = nee_->refit_possible();
    auto pass =
        PassScope(&recorder_, recorder_.begin_pass(refit ? "light-bvh/refit" : "light-bvh/build"));
    nee_->update(scene_, state_);
    nee_lights_changed_ = false;
  }
  // The G-buffer on the host: what is recorded so far runs now.
  host_.flush();
  device_.read_image(position_, gbuffer_position_);
  device_.read_image(normal_, gbuffer_normal_);
  const trace::EmbreeScene& world = host_.embree();
  trace::GBufferSamples samples{&gbuffer_position_, &gbuffer_normal_, width_, height_,
                                camera_.position};
  // A stream per frame and cell seed (the seed axis scrambles it), per pixel.
  uint64_t seed =
      (uint64_t(state_.frame) << 32) ^ (host_.seed ? host_.seed() : 0) ^ 0x9e3779b97f4a7c15ull;
  {
    auto pass = PassScope(&recorder_, recorder_.begin_pass("nee/sample"));
    nee_->sample(scene_, samples, seed);
  }
  {
    auto pass = PassScope(&recorder_, recorder_.begin_pass("nee/trace"));
    nee_->trace(world);
  }
  {
    auto pass = PassScope(&recorder_, recorder_.begin_pass("nee/shade"));
    nee_->shade(scene_, world, nee_radiance_);
    size_t bytes = nee_radiance_.size() * sizeof(float);
    if (!direct_upload_ || direct_upload_.size() < bytes)
      direct_upload_ = device_.create_buffer(
          "direct/nee-upload", bytes, vk::BufferUsageFlagBits::eTransferSrc, Memory::host_visible);
    std::memcpy(direct_upload_.mapped(), nee_radiance_.data(), bytes);
    vk::CommandBuffer cmd = cmd_();
    full_barrier(cmd);
    vk::BufferImageCopy region{
        0, 0, 0, {vk::ImageAspectFlagBits::eColor, 0, 0, 1}, {0, 0, 0}, {width_, height_, 1}};
    cmd.copyBufferToImage(direct_upload_.handle(), direct_.handle(), vk::ImageLayout::eGeneral,
                          region);
    full_barrier(cmd);
  }
  if (host_.count) {
    const trace::NeeStats& stats = nee_->stats();
    auto count = [&](size_t row, double value) {
      const pb_counter_spec& c = kCounters[row];
      host_.count(Counter{c.name, CounterKind(c.kind), c.unit}, value);
    };
    count(0, double(nee_->lights().lights.size()));
    count(1, double(nee_->lights().culled));
    count(2, double(nee_->tree_nodes()));
    count(3, double(nee_->tree_bytes()));
    count(4, stats.samples ? double(stats.nodes_visited) / double(stats.samples) : 0.0);
    count(5, double(stats.shadow_rays));
    count(6, stats.shadow_rays ? double(stats.occluded) / double(stats.shadow_rays) : 0.0);
  }
}

void ScenePasses::shade(const Image* indirect_radiance) {
  indirect_estimate_ = indirect_radiance;
  auto scope = PassScope(&recorder_, recorder_.begin_pass("shade"));
  vk::CommandBuffer cmd = cmd_();
  uint32_t has_indirect = indirect_radiance ? 1u : 0u;
  shade_pipeline_.bind(cmd,
                       {&frame_, &materials_, &position_, &normal_, &direct_,
                        indirect_radiance ? indirect_radiance : &direct_, &final_},
                       has_indirect);
  cmd.dispatch(groups_for(width_, kGroup), groups_for(height_, kGroup), 1);
}

SceneTriangles ScenePasses::scene_triangles() {
  if (!world_triangles_) {
    using U = vk::BufferUsageFlagBits;
    world_triangles_ = std::make_unique<scene::WorldTriangles>(scene_);
    auto bytes = [](auto records) { return std::max<size_t>(records.size_bytes(), 16); };
    scene_vertices_ =
        device_.create_buffer("world/scene-vertices", bytes(world_triangles_->vertices()),
                              U::eStorageBuffer, Memory::host_visible);
    scene_triangles_ =
        device_.create_buffer("world/scene-triangles", bytes(world_triangles_->triangles()),
                              U::eStorageBuffer, Memory::host_visible);
    std::vector<scene::Mesh> deformed;
    for (uint32_t i : state_.deformed_objects) deformed.push_back(scene_.mesh_at(i, state_.time));
    refresh_triangles(state_, deformed);
  }
  const scene::WorldTriangles& w = *world_triangles_;
  return SceneTriangles{&scene_vertices_,        &scene_triangles_,  w.vertices(),
                        w.triangles(),           w.first_triangle(), w.total_area(),
                        triangles_changed_frame_};
}

void ScenePasses::refresh_triangles(const scene::FrameState& state,
                                    std::span<const scene::Mesh> deformed) {
  const std::vector<uint32_t>& changed = world_triangles_->update(state, deformed);
  if (changed.empty()) return;
  triangles_changed_frame_ = state.frame;
  // Host-visible and written in place: the previous frame's commands have completed by the
  // scene-update pass. Only the objects that changed are copied.
  auto copy = [](const Buffer& buffer, auto records, uint32_t first, uint32_t end) {
    std::memcpy(static_cast<char*>(buffer.mapped()) + size_t(first) * sizeof(records[0]),
                records.data() + first, size_t(end - first) * sizeof(records[0]));
  };
  const scene::WorldTriangles& w = *world_triangles_;
  for (uint32_t o : changed) {
    copy(scene_vertices_, w.vertices(), w.first_vertex()[o], w.first_vertex()[o + 1]);
    copy(scene_triangles_, w.triangles(), w.first_triangle()[o], w.first_triangle()[o + 1]);
  }
}

void ScenePasses::draw_scene(const SceneTarget& target, std::optional<glm::mat4> view_projection) {
  const Image* colors[3] = {target.position, target.normal, target.triangle};
  const vk::Format formats[3] = {kColor, kColor, vk::Format::eR32Uint};
  const char* names[3] = {"position", "normal", "triangle"};
  if (!target.depth || target.depth->format() != kDepth)
    throw Error("draw_scene: the target's depth image must be D32_SFLOAT");
  const vk::Extent2D extent = target.depth->extent();
  for (int i = 0; i < 3; ++i) {
    if (!colors[i] || colors[i]->format() != formats[i] || colors[i]->extent() != extent)
      throw Error(fmt::format("draw_scene: the target's {} image must be {}, {}x{} as its depth",
                              names[i], vk::to_string(formats[i]), extent.width, extent.height));
  }
  vk::Rect2D area = target.area.extent.width == 0 ? vk::Rect2D{{0, 0}, extent} : target.area;
  if (area.offset.x < 0 || area.offset.y < 0 ||
      uint64_t(area.offset.x) + area.extent.width > extent.width ||
      uint64_t(area.offset.y) + area.extent.height > extent.height)
    throw Error(fmt::format("draw_scene: area ({}, {}) + {}x{} outside the {}x{} target",
                            area.offset.x, area.offset.y, area.extent.width, area.extent.height,
                            extent.width, extent.height));
  SceneTriangles triangles = scene_triangles();
  if (!draw_scene_pipeline_) {
    GraphicsPipelineDesc desc{"draw-scene",
                              kdraw_scene_vert_spv,
                              kdraw_scene_frag_spv,
                              {Binding::storage_buffer, Binding::storage_buffer},
                              sizeof(DrawScenePush),
                              0,  // no vertex input: the vertex shader pulls the triangle records
                              {},
                              {formats[0], formats[1], formats[2]},
                              kDepth};
    draw_scene_pipeline_ = device_.create_graphics_pipeline(desc);
  }
  auto scope = PassScope(&recorder_, recorder_.begin_pass("draw-scene"));
  vk::CommandBuffer cmd = cmd_();
  const vk::ClearColorValue clears[3] = {vk::ClearColorValue(std::array<float, 4>{0, 0, 0, 0}),
                                         vk::ClearColorValue(std::array<float, 4>{0, 0, 0, 0}),
                                         vk::ClearColorValue(std::array<uint32_t, 4>{
                                             kNoTriangle, kNoTriangle, kNoTriangle, kNoTriangle})};
  begin_raster(device_, cmd, colors, clears, *target.depth, area);
  DrawScenePush push{view_projection.value_or(camera_.view_projection),
                     view_projection ? eye_of(*view_projection) : glm::vec4(camera_.position, 1.f)};
  draw_scene_pipeline_->bind(cmd, {triangles.vertices, triangles.triangles}, push);
  if (triangles.triangle_count() > 0) cmd.draw(3 * triangles.triangle_count(), 1, 0, 0);
  device_.end_rendering(cmd);
}

}  // namespace pb::gpu
