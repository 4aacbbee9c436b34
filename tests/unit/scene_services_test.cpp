// The scene services of the plugin API: the scene's triangles (pb::SceneTriangles) against the
// scene's meshes and its animation, the triangle id of every stored photon, draw_scene's targets
// against Embree's hits, and the GPU layouts of the photon and triangle records as GLSL lays them
// out.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <glm/gtc/matrix_transform.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "cell/profiler.h"
#include "command_stream.h"
#include "gpu/shared_passes.h"
#include "photonbench/error.h"
#include "photonbench/photons.h"
#include "photonbench/scene_layout.h"
#include "scene/scene.h"
#include "scene/world_triangles.h"
#include "scene_services_test_shaders.h"
#include "trace/embree_scene.h"
#include "trace/photon_tracer.h"
#include "validation.h"

namespace pb {
namespace scene_services_test {

using layout::GpuSceneTriangle;
using layout::GpuSceneVertex;

scene::Scene dynamic_room() {
  return scene::load_scene(std::string(PB_SOURCE_DIR) + "/scenes/dynamic-room.yaml");
}

uint32_t object_named(const scene::Scene& scene, const std::string& name) {
  for (uint32_t o = 0; o < scene.objects.size(); ++o)
    if (scene.objects[o].name == name) return o;
  ADD_FAILURE() << "no object " << name;
  return 0;
}

// The scene's passes on a device of their own, recording into one command stream; with the
// validation layers where the test runs with them (validation_on()), whose errors fail it.
struct Passes {
  explicit Passes(const scene::Scene& scene, uint32_t width = 96, uint32_t height = 72)
      : device({"", pb::testing::validation_on()}),
        commands(device),
        profiler(device, [this] { return commands.cmd(); }),
        passes(device, scene, width, height, {}, profiler, [this] { return commands.cmd(); }) {}
  // Records `draw` as a frame does (the profiler's queries reset first), submits it and waits.
  template <class Draw>
  void frame(const Draw& draw) {
    profiler.begin_frame();
    commands.begin();
    draw();
    commands.submit();
    profiler.end_frame();
  }
  ~Passes() { EXPECT_EQ(device.validation_errors(), 0u) << device.first_validation_error(); }
  gpu::Device device;
  testing::CommandStream commands;
  run::Profiler profiler;
  gpu::ScenePasses passes;
};

glm::vec3 position(const SceneTriangles& t, uint32_t triangle, int corner) {
  return glm::vec3(t.host_vertices[t.host_triangles[triangle].vertices_object[corner]].position);
}

// The GPU buffers hold exactly the host records.
void expect_gpu_equals_host(const SceneTriangles& t) {
  ASSERT_GE(t.vertices->size(), t.host_vertices.size_bytes());
  ASSERT_GE(t.triangles->size(), t.host_triangles.size_bytes());
  EXPECT_EQ(std::memcmp(t.vertices->mapped(), t.host_vertices.data(), t.host_vertices.size_bytes()),
            0);
  EXPECT_EQ(
      std::memcmp(t.triangles->mapped(), t.host_triangles.data(), t.host_triangles.size_bytes()),
      0);
}

// ---- the scene's triangles

TEST(SceneTriangles, MatchTheScenesMeshesAndAreas) {
  scene::Scene scene = dynamic_room();
  Passes p(scene);
  const scene::FrameState state = scene.at(0);
  p.passes.update(state);
  SceneTriangles t = p.passes.scene_triangles();

  size_t triangles = 0;
  double area = 0;  // computed here in double from the object-space meshes and transforms
  for (uint32_t o = 0; o < scene.objects.size(); ++o) {
    const scene::Mesh& mesh = scene.objects[o].mesh;
    ASSERT_EQ(t.first_triangle[o], triangles) << scene.objects[o].name;
    glm::dmat4 to_world(state.object_to_world[o]);
    for (size_t k = 0; k < mesh.triangles.size(); ++k) {
      const uint32_t id = uint32_t(triangles + k);
      glm::dvec3 w[3];
      for (int c = 0; c < 3; ++c) {
        w[c] = glm::dvec3(to_world * glm::dvec4(mesh.positions[mesh.triangles[k][c]], 1.0));
        EXPECT_LT(glm::length(glm::dvec3(position(t, id, c)) - w[c]), 1e-5) << id;
      }
      double a = 0.5 * glm::length(glm::cross(w[1] - w[0], w[2] - w[0]));
      EXPECT_NEAR(t.area(id), a, 1e-6 * std::max(a, 1.0)) << id;
      area += a;
      EXPECT_EQ(t.object(id), o);
      EXPECT_EQ(t.material(id), scene.objects[o].material);
      EXPECT_EQ(t.host_triangles[id].material_local.y, k);
    }
    triangles += mesh.triangles.size();
  }
  EXPECT_EQ(t.triangle_count(), triangles);
  EXPECT_EQ(t.first_triangle.back(), triangles);
  EXPECT_NEAR(t.total_area, area, 1e-6 * area);
  // The floor is a 5 x 5 m quad.
  const uint32_t floor = object_named(scene, "floor");
  double floor_area = 0;
  for (uint32_t id = t.first_triangle[floor]; id < t.first_triangle[floor + 1]; ++id)
    floor_area += t.area(id);
  EXPECT_NEAR(floor_area, 25.0, 1e-4);
  expect_gpu_equals_host(t);
}

TEST(SceneTriangles, FollowTheAnimationOnlyWhenTheSceneChanged) {
  scene::Scene scene = dynamic_room();
  Passes p(scene);
  p.passes.update(scene.at(0));
  SceneTriangles t = p.passes.scene_triangles();
  EXPECT_EQ(t.changed_frame, 0u);
  const uint32_t ball = object_named(scene, "ball"), column = object_named(scene, "column");
  const uint32_t ball_triangle = t.first_triangle[ball], column_triangle = t.first_triangle[column];
  const glm::vec3 ball_before = position(t, ball_triangle, 0);
  const glm::vec3 column_before = position(t, column_triangle, 0);

  const scene::FrameState later = scene.at(15);
  p.passes.update(later);
  t = p.passes.scene_triangles();
  EXPECT_EQ(t.changed_frame, 15u);
  const glm::vec3 ball_after = position(t, ball_triangle, 0);
  const scene::Mesh& ball_mesh = scene.objects[ball].mesh;
  glm::vec3 expected = glm::vec3(later.object_to_world[ball] *
                                 glm::vec4(ball_mesh.positions[ball_mesh.triangles[0].x], 1.f));
  EXPECT_LT(glm::length(ball_after - expected), 1e-5f);
  EXPECT_GT(glm::length(ball_after - ball_before), 0.05f);    // it orbits at about 1.3 m/s
  EXPECT_EQ(position(t, column_triangle, 0), column_before);  // the column stands still
  expect_gpu_equals_host(t);

  // The same frame again: nothing moved, nothing is rewritten.
  p.passes.update(later);
  EXPECT_EQ(p.passes.scene_triangles().changed_frame, 15u);
}

// ---- a triangle id on every photon

trace::TraceSettings photon_settings() {
  trace::TraceSettings settings;
  settings.paths = 20000;
  settings.store = trace::kAllPhotons;
  settings.max_bounces = 4;
  settings.keep_light_paths = true;
  return settings;
}

// Every stored photon names a triangle whose plane holds it (1e-4 relative to the coordinates) and
// that contains it (barycentric weights not below -1e-4): a photon given its quad's other triangle,
// coplanar with it, fails the second.
void expect_photons_on_their_triangles(const scene::Scene& scene, const scene::FrameState& state,
                                       const trace::PhotonBatch& batch) {
  ASSERT_GT(batch.photons.size(), 5000u);
  scene::WorldTriangles triangles(scene);
  std::vector<scene::Mesh> deformed;
  for (uint32_t o : state.deformed_objects) deformed.push_back(scene.mesh_at(o, state.time));
  triangles.update(state, deformed);
  size_t wrong = 0;
  for (const trace::PhotonRecord& photon : batch.photons) {
    ASSERT_LT(photon.triangle, triangles.triangles().size());
    const GpuSceneTriangle& record = triangles.triangles()[photon.triangle];
    glm::vec3 p[3];
    for (int c = 0; c < 3; ++c)
      p[c] = glm::vec3(triangles.vertices()[record.vertices_object[c]].position);
    const glm::vec3 x = photon.position, n = glm::vec3(record.normal_area);
    const float scale = std::max({1.f, std::abs(x.x), std::abs(x.y), std::abs(x.z)});
    const bool in_plane = std::abs(glm::dot(n, x - p[0])) <= 1e-4f * scale;
    // Barycentric weights of x in the triangle's plane.
    const glm::vec3 e1 = p[1] - p[0], e2 = p[2] - p[0], d = x - p[0];
    const float d11 = glm::dot(e1, e1), d12 = glm::dot(e1, e2), d22 = glm::dot(e2, e2);
    const float denominator = d11 * d22 - d12 * d12;
    const float v = (d22 * glm::dot(d, e1) - d12 * glm::dot(d, e2)) / denominator;
    const float w = (d11 * glm::dot(d, e2) - d12 * glm::dot(d, e1)) / denominator;
    const bool inside = v >= -1e-4f && w >= -1e-4f && v + w <= 1.f + 1e-4f;
    if (!in_plane || !inside) ++wrong;
  }
  EXPECT_EQ(wrong, 0u) << "of " << batch.photons.size() << " photons";
}

TEST(PhotonTriangles, EveryPhotonLiesOnItsTriangle) {
  scene::Scene scene = dynamic_room();
  for (uint32_t frame : {0u, 40u}) {  // the second after every moving object has moved
    const scene::FrameState state = scene.at(frame);
    trace::EmbreeScene world(scene, state);
    trace::EmbreePhotonTracer tracer(world);
    trace::PhotonBatch batch;
    tracer.trace(photon_settings(), batch);
    expect_photons_on_their_triangles(scene, state, batch);
  }
}

// Path verification's error-based reuse moves kept photons with the objects they lie on (Paper II
// §3.3): their triangle ids move with them.
TEST(PhotonTriangles, PhotonsMovedByPathVerificationKeepTheirTriangle) {
  scene::Scene scene = dynamic_room();
  trace::EmbreeScene world(scene, scene.at(0));
  trace::EmbreePhotonTracer tracer(world);
  trace::PhotonBatch batch;
  const trace::TraceSettings settings = photon_settings();
  tracer.trace(settings, batch);
  const scene::FrameState later = scene.at(2);
  world.update(later);
  trace::ReuseSettings reuse;
  reuse.rule = trace::ReuseRule::error_based;
  reuse.energy_threshold = 1.f;  // keep (and move) every vertex whose energy changed by < 100%
  trace::TraceStats verified = tracer.verify_paths(settings, reuse, batch);
  EXPECT_GT(verified.paths_moved, 100u);
  tracer.retrace_marked(settings, batch);
  expect_photons_on_their_triangles(scene, later, batch);
}

// ---- draw_scene

struct Target {
  Target(gpu::Device& device, uint32_t width, uint32_t height) {
    using I = vk::ImageUsageFlagBits;
    auto usage = I::eColorAttachment | I::eTransferSrc;
    position = device.create_image("test/position", {width, height},
                                   vk::Format::eR32G32B32A32Sfloat, usage);
    normal =
        device.create_image("test/normal", {width, height}, vk::Format::eR32G32B32A32Sfloat, usage);
    triangle = device.create_image("test/triangle", {width, height}, vk::Format::eR32Uint, usage);
    depth = device.create_image("test/depth", {width, height}, vk::Format::eD32Sfloat,
                                I::eDepthStencilAttachment);
  }
  SceneTarget target(vk::Rect2D area = {}) const {
    return SceneTarget{&position, &normal, &triangle, &depth, area};
  }
  gpu::Image position, normal, triangle, depth;
};

std::vector<uint32_t> read_uints(gpu::Device& device, const gpu::Image& image) {
  auto extent = image.extent();
  vk::DeviceSize bytes = vk::DeviceSize(extent.width) * extent.height * 4;
  gpu::Buffer staging = device.create_buffer(
      "test/readback", bytes, vk::BufferUsageFlagBits::eTransferDst, gpu::Memory::host_visible);
  device.submit_and_wait([&](vk::CommandBuffer cmd) {
    gpu::full_barrier(cmd);
    vk::BufferImageCopy region{0,         0,
                               0,         {vk::ImageAspectFlagBits::eColor, 0, 0, 1},
                               {0, 0, 0}, {extent.width, extent.height, 1}};
    cmd.copyImageToBuffer(image.handle(), vk::ImageLayout::eGeneral, staging.handle(), region);
  });
  std::vector<uint32_t> out(size_t(extent.width) * extent.height);
  std::memcpy(out.data(), staging.mapped(), bytes);
  return out;
}

struct DrawCheck {
  int checked = 0, background = 0;
};

// Compares draw_scene's targets drawn with `view_projection` against Embree's closest hit along
// each chosen pixel's centre ray (a grid of pixels; those whose hit lies within 2% of its
// triangle's edges are skipped, where rasterisation and ray casting may rightly disagree).
DrawCheck check_against_embree(const scene::Scene& scene, const scene::FrameState& state, Passes& p,
                               const glm::mat4& view_projection, bool camera) {
  const uint32_t width = 96, height = 72;
  Target target(p.device, width, height);
  p.frame([&] {
    if (camera)
      p.passes.draw_scene(target.target());
    else
      p.passes.draw_scene(target.target(), view_projection);
  });
  std::vector<uint32_t> ids = read_uints(p.device, target.triangle);
  std::vector<float> positions, normals;
  p.device.read_image(target.position, positions);
  p.device.read_image(target.normal, normals);
  SceneTriangles t = p.passes.scene_triangles();

  trace::EmbreeOptions options;
  options.area_lights_as_geometry = false;  // lights are not drawn
  trace::EmbreeScene world(scene, state, options);
  const glm::mat4 inverse = glm::inverse(view_projection);
  DrawCheck result;
  for (uint32_t y = 3; y < height; y += 6)
    for (uint32_t x = 3; x < width; x += 6) {
      glm::vec2 ndc((x + 0.5f) / width * 2.f - 1.f, (y + 0.5f) / height * 2.f - 1.f);
      glm::vec4 near = inverse * glm::vec4(ndc, 0.f, 1.f), far = inverse * glm::vec4(ndc, 1.f, 1.f);
      glm::vec3 origin = glm::vec3(near) / near.w, end = glm::vec3(far) / far.w;
      trace::Hit hit;
      const size_t i = size_t(y) * width + x;
      if (!world.intersect(origin, end - origin, 1.f, hit)) {
        EXPECT_EQ(ids[i], kNoTriangle) << x << "," << y;
        ++result.background;
        continue;
      }
      const float u = hit.barycentric.x, v = hit.barycentric.y;
      if (std::min({u, v, 1.f - u - v}) < 0.02f) continue;
      const uint32_t expected = world.scene_triangle(hit.object, hit.primitive);
      EXPECT_EQ(ids[i], expected) << "pixel " << x << "," << y;
      // The drawn position lies in the triangle's plane, near the hit (rasterisation snaps
      // vertices to sub-pixel positions, which moves a grazing surface's points by millimetres).
      glm::vec3 drawn(positions[4 * i], positions[4 * i + 1], positions[4 * i + 2]);
      glm::vec3 corner =
          glm::vec3(t.host_vertices[t.host_triangles[expected].vertices_object.x].position);
      EXPECT_LT(
          std::abs(glm::dot(glm::vec3(t.host_triangles[expected].normal_area), drawn - corner)),
          1e-4f * std::max(1.f, glm::length(drawn)));
      EXPECT_LT(glm::length(drawn - hit.position), 0.01f * glm::length(hit.position - origin));
      EXPECT_EQ(positions[4 * i + 3], 1.f);
      EXPECT_EQ(normals[4 * i + 3], float(t.material(expected)));
      glm::vec3 n(normals[4 * i], normals[4 * i + 1], normals[4 * i + 2]);
      EXPECT_GT(glm::dot(n, origin - hit.position), 0.f) << "the normal faces the viewer";
      ++result.checked;
    }
  return result;
}

TEST(DrawScene, WritesTheTriangleEmbreeHitsWithTheFramesCamera) {
  scene::Scene scene = dynamic_room();
  Passes p(scene);
  const scene::FrameState state = scene.at(20);
  p.passes.update(state);
  DrawCheck check =
      check_against_embree(scene, state, p, p.passes.camera_view().view_projection, true);
  EXPECT_GT(check.checked, 120);  // of the grid's 192 pixels
}

// A light's orthographic view from under the ceiling, looking down (Vulkan clip space: y flipped).
TEST(DrawScene, WritesTheTriangleEmbreeHitsWithAViewProjectionItIsGiven) {
  scene::Scene scene = dynamic_room();
  Passes p(scene);
  const scene::FrameState state = scene.at(20);
  p.passes.update(state);
  glm::mat4 projection = glm::orthoRH_ZO(-2.5f, 2.5f, -1.875f, 1.875f, 0.01f, 4.f);
  projection[1][1] *= -1.f;
  glm::mat4 view = glm::lookAtRH(glm::vec3(0, 2.95f, 0), glm::vec3(0, 0, 0), glm::vec3(0, 0, -1));
  DrawCheck check = check_against_embree(scene, state, p, projection * view, false);
  EXPECT_GT(check.checked, 120);
  EXPECT_EQ(check.background, 0);  // the room is closed
}

// Two views side by side in one target (an atlas): each area holds what a target of its own would.
TEST(DrawScene, DrawsIntoAnAreaOfItsTarget) {
  scene::Scene scene = dynamic_room();
  Passes p(scene);
  p.passes.update(scene.at(0));
  const uint32_t width = 48, height = 36;
  Target whole(p.device, width, height), atlas(p.device, 2 * width, height);
  p.frame([&] {
    p.passes.draw_scene(whole.target());
    p.passes.draw_scene(atlas.target({{0, 0}, {width, height}}));
    p.passes.draw_scene(atlas.target({{int32_t(width), 0}, {width, height}}));
  });
  std::vector<uint32_t> one = read_uints(p.device, whole.triangle);
  std::vector<uint32_t> two = read_uints(p.device, atlas.triangle);
  int drawn = 0;
  for (uint32_t y = 0; y < height; ++y)
    for (uint32_t x = 0; x < width; ++x) {
      const uint32_t id = one[y * width + x];
      drawn += id != kNoTriangle;
      ASSERT_EQ(two[y * 2 * width + x], id) << x << "," << y;
      ASSERT_EQ(two[y * 2 * width + width + x], id) << x << "," << y;
    }
  EXPECT_EQ(drawn, int(width * height));  // the camera is inside the closed room
  EXPECT_THROW(p.passes.draw_scene(atlas.target({{int32_t(width) + 1, 0}, {width, height}})),
               Error);
  SceneTarget wrong = whole.target();
  wrong.triangle = &whole.position;  // RGBA32F where R32_UINT is needed
  EXPECT_THROW(p.passes.draw_scene(wrong), Error);
}

// ---- the GPU layouts as GLSL lays them out

// Element 1 of `buffer` holds each 4-byte word's index within the element, as a float where
// `types` says 'f' and as a uint where it says 'u', and element 0 is untouched (0xff bytes).
void expect_word_indices(const gpu::Buffer& buffer, std::string_view types) {
  const auto* bytes = static_cast<const uint8_t*>(buffer.mapped());
  const size_t size = types.size() * 4;
  ASSERT_EQ(buffer.size(), 2 * size) << "two elements of the C++ size";
  EXPECT_TRUE(std::all_of(bytes, bytes + size, [](uint8_t x) { return x == 0xff; }));
  for (uint32_t i = 0; i < types.size(); ++i) {
    uint32_t word, expected = i;
    std::memcpy(&word, bytes + size + 4 * i, 4);
    if (types[i] == 'f') {
      const float f = float(i);
      std::memcpy(&expected, &f, 4);
    }
    EXPECT_EQ(word, expected) << "word " << i;
  }
}

// The shader fills element 1 of a PhotonRecord, GpuSceneVertex and GpuSceneTriangle array with
// each word's index. Each word in the place and of the type the C++ struct has it (their offsets
// are static_asserted in photons.h and shared_passes.cpp), and element 1 starting at the C++ size,
// say that the std430 layouts are the C++ ones.
TEST(GpuLayouts, GlslAndCppAgreeOnThePhotonAndTriangleRecords) {
  gpu::Device device({"", false});
  auto buffer = [&](const char* name, size_t bytes) {
    gpu::Buffer b = device.create_buffer(name, 2 * bytes, vk::BufferUsageFlagBits::eStorageBuffer,
                                         gpu::Memory::host_visible);
    std::memset(b.mapped(), 0xff, 2 * bytes);
    return b;
  };
  gpu::Buffer photons = buffer("test/photons", sizeof(trace::PhotonRecord));
  gpu::Buffer vertices = buffer("test/vertices", sizeof(GpuSceneVertex));
  gpu::Buffer triangles = buffer("test/triangles", sizeof(GpuSceneTriangle));
  auto pipeline = device.create_compute_pipeline(
      "test/layouts", kscene_services_test_layouts_comp_spv,
      {gpu::Binding::storage_buffer, gpu::Binding::storage_buffer, gpu::Binding::storage_buffer},
      0);
  device.submit_and_wait([&](vk::CommandBuffer cmd) {
    pipeline.bind(cmd, {&photons, &vertices, &triangles});
    cmd.dispatch(1, 1, 1);
    gpu::full_barrier(cmd);
  });
  // position triangle, power path, direction bounce, normal specular_mask, footprint_u light,
  // footprint_v flags
  expect_word_indices(photons, "fffufffufffufffufffufffu");
  expect_word_indices(vertices, "ffffffff");       // position, normal
  expect_word_indices(triangles, "uuuuffffuuuu");  // vertices_object, normal_area, material_local
  EXPECT_EQ(offsetof(trace::PhotonRecord, triangle), 12u);
}

}  // namespace scene_services_test
}  // namespace pb
