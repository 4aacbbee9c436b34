// Camera paths (photonbench/camera_paths.h, src/trace/camera_paths.cpp) against closed forms: the
// primary rays are the G-buffer's (the reference's camera rays through pixel centres); behind a
// mirror, the position is the mirror image of the unfolded ray and the throughput the mirror's
// tint; a glass slab reflects a fraction F of the paths (Fresnel) and passes the rest with
// throughput 1; a path whose first hit is diffuse stops there; max_bounces ends paths between two
// mirrors; the ray cone's width is the spread angle times the path's length; the result does not
// depend on the thread count.
#include "photonbench/camera_paths.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <cstring>

#include "photonbench/error.h"
#include "reference/reference.h"
#include "test_scenes.h"
#include "trace/bsdf.h"
#include "trace/camera_paths.h"
#include "trace/embree_scene.h"

namespace pb::trace {
namespace camera_paths_test {

using namespace test_scenes;

// The camera as the G-buffer rasterises it (cell/world's passes: view, then Vulkan projection).
CameraPathCamera rig(const scene::Camera& c, uint32_t width, uint32_t height) {
  const glm::mat4 view_projection = c.projection(float(width) / float(height)) * c.view();
  return {c.position, glm::inverse(view_projection), c.fov_y, width, height};
}

// The camera at the origin looking down -z.
void look_down_z(TestScene& ts, float fov_deg) {
  ts.camera({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, fov_deg);
}

// The paths of a w x h image of the scene, seen from the origin looking down -z.
CameraPathBatch paths_down_z(TestScene& ts, float fov_deg, uint32_t w, uint32_t h,
                             const CameraPathSettings& settings = {}) {
  look_down_z(ts, fov_deg);
  const EmbreeScene world(ts.scene, ts.state);
  CameraPathBatch batch;
  trace_camera_paths(world, rig(ts.state.camera, w, h), 0, std::nullopt, settings, batch);
  return batch;
}

uint32_t tinted_mirror(TestScene& ts, glm::vec3 tint) {
  const uint32_t m = ts.material(scene::MaterialType::mirror);
  ts.scene.materials[m].specular = tint;
  return m;
}

// The primary ray's unit direction of pixel p: the reference renderer's camera ray through the
// pixel's centre.
glm::vec3 primary(const TestScene& ts, uint32_t width, uint32_t height, uint32_t p) {
  return camera_ray(ts.state.camera, int(width), int(height), float(p % width) + 0.5f,
                    float(p / width) + 0.5f)
      .direction;
}

void expect_near(const glm::vec3& a, const glm::vec3& b, float tolerance, const char* what,
                 uint32_t pixel) {
  EXPECT_NEAR(glm::length(a - b), 0.f, tolerance)
      << what << " at pixel " << pixel << ": (" << a.x << ", " << a.y << ", " << a.z << ") vs ("
      << b.x << ", " << b.y << ", " << b.z << ")";
}

TEST(CameraPaths, FirstDiffuseHitEndsThePathAtOnce) {
  TestScene ts;
  const uint32_t wall = ts.material(scene::MaterialType::diffuse);
  ts.object(quad_mesh({-5, -5, -3}, {10, 0, 0}, {0, 10, 0}), wall);  // z = -3, facing +z
  const uint32_t w = 7, h = 5;
  const CameraPathBatch batch = paths_down_z(ts, 40, w, h);
  ASSERT_EQ(batch.paths.size(), size_t(w * h));
  EXPECT_EQ(batch.rays, uint64_t(w * h));  // one segment each
  const float gamma = pixel_spread_angle(ts.state.camera.fov_y, h);
  EXPECT_FLOAT_EQ(gamma, std::atan(2.f * std::tan(glm::radians(20.f)) / 5.f));
  for (uint32_t p = 0; p < w * h; ++p) {
    const CameraPathRecord& path = batch.paths[p];
    const glm::vec3 d = primary(ts, w, h, p);
    const float t = 3.f / -d.z;
    EXPECT_EQ(path.pixel, p);
    EXPECT_TRUE(ends_diffuse(path)) << p;
    EXPECT_EQ(specular_vertices(path), 0u) << p;
    EXPECT_EQ(path.material, wall);
    expect_near(path.segment_direction, d, 1e-5f, "direction", p);
    expect_near(path.segment_origin, glm::vec3(0.f), 0.f, "origin", p);
    expect_near(path.position, d * t, 1e-4f, "position", p);
    expect_near(path.normal, {0, 0, 1}, 1e-5f, "normal", p);
    expect_near(path.throughput, glm::vec3(1.f), 0.f, "throughput", p);
    EXPECT_NEAR(path.segment_length, t, 1e-4f) << p;
    EXPECT_NEAR(path.cone_width, gamma * t, 1e-6f) << p;
  }
}

TEST(CameraPaths, MirrorShowsTheWallBehindTheCameraWithItsTint) {
  TestScene ts;
  const glm::vec3 tint{0.9f, 0.8f, 0.7f};
  ts.object(quad_mesh({-2, -2, -2}, {4, 0, 0}, {0, 4, 0}), tinted_mirror(ts, tint));  // z = -2
  const uint32_t wall = ts.material(scene::MaterialType::diffuse);
  ts.object(quad_mesh({-5, -5, 3}, {0, 10, 0}, {10, 0, 0}), wall);  // z = 3, facing -z
  const uint32_t w = 9, h = 6;
  const CameraPathBatch batch = paths_down_z(ts, 40, w, h);
  const float gamma = pixel_spread_angle(ts.state.camera.fov_y, h);
  for (uint32_t p = 0; p < w * h; ++p) {
    const CameraPathRecord& path = batch.paths[p];
    const glm::vec3 d = primary(ts, w, h, p);
    // Unfolded, the ray runs to the wall's mirror image at z = -2 - 5 = -7; folded back, x and y
    // stay and z is the wall's.
    const float length = 7.f / -d.z;
    const glm::vec3 unfolded = d * length;
    ASSERT_TRUE(ends_diffuse(path)) << p;
    EXPECT_EQ(specular_vertices(path), 1u) << p;
    EXPECT_EQ(path.material, wall);
    // (The ray leaves the mirror from a point moved off it by EmbreeScene::ray_epsilon: 1e-3.)
    expect_near(path.position, {unfolded.x, unfolded.y, 3.f}, 1e-3f, "position", p);
    expect_near(path.throughput, tint, 1e-6f, "throughput", p);
    expect_near(path.normal, {0, 0, -1}, 1e-5f, "normal", p);
    expect_near(path.segment_origin, d * (2.f / -d.z), 1e-4f, "segment origin", p);
    expect_near(path.segment_direction, {d.x, d.y, -d.z}, 1e-5f, "segment direction", p);
    EXPECT_NEAR(path.segment_length, 5.f / -d.z, 1e-3f) << p;
    // The cone grows over the whole path: gamma times its length, mirror or not.
    EXPECT_NEAR(path.cone_width, gamma * length, 1e-5f) << p;
  }
}

TEST(CameraPaths, GlassSlabReflectsTheFresnelShare) {
  TestScene ts;
  const uint32_t glass = ts.material(scene::MaterialType::dielectric);
  ts.scene.materials[glass].ior = 1.5f;
  ts.object(box_mesh({-3, -3, -2.2f}, {3, 3, -2}, false), glass);
  const uint32_t ahead = ts.material(scene::MaterialType::diffuse);
  const uint32_t behind = ts.material(scene::MaterialType::diffuse);
  ts.object(quad_mesh({-9, -9, -5}, {18, 0, 0}, {0, 18, 0}), ahead);  // z = -5, facing +z
  ts.object(quad_mesh({-9, -9, 3}, {0, 18, 0}, {18, 0, 0}), behind);  // z = 3, facing -z
  const uint32_t w = 160, h = 120;
  const CameraPathBatch batch = paths_down_z(ts, 50, w, h);
  double expected = 0, variance = 0;
  uint32_t reflected = 0, through = 0;
  for (uint32_t p = 0; p < w * h; ++p) {
    const CameraPathRecord& path = batch.paths[p];
    ASSERT_TRUE(ends_diffuse(path)) << p;
    const double f = fresnel_dielectric(-primary(ts, w, h, p).z, 1.5f);
    expected += f;
    variance += f * (1 - f);
    if (specular_vertices(path) == 1) {
      EXPECT_EQ(path.material, behind) << p;
      ++reflected;
    }
    if (specular_vertices(path) == 2) {
      // In and out of the glass: the radiance scale (eta_i / eta_t)^2 of one refraction undoes the
      // other's, and the lobe's probability equals its Fresnel weight.
      EXPECT_EQ(path.material, ahead) << p;
      expect_near(path.throughput, glm::vec3(1.f), 1e-5f, "throughput", p);
      ++through;
    }
    if (specular_vertices(path) == 1) expect_near(path.throughput, glm::vec3(1.f), 1e-6f, "F/F", p);
  }
  // About 4% of 19200 paths: the count within four standard deviations of the sum of F.
  EXPECT_NEAR(reflected, expected, 4 * std::sqrt(variance)) << "expected " << expected;
  EXPECT_GT(reflected, 0.02 * w * h);
  EXPECT_GT(through, 0.9 * w * h);
}

TEST(CameraPaths, MaxBouncesEndsPathsBetweenTwoMirrors) {
  TestScene ts;
  const glm::vec3 tint{0.9f, 0.5f, 0.25f};
  const uint32_t mirror = tinted_mirror(ts, tint);
  ts.object(quad_mesh({-100, -100, -1}, {200, 0, 0}, {0, 200, 0}), mirror);  // z = -1, facing +z
  ts.object(quad_mesh({-100, -100, 1}, {0, 200, 0}, {200, 0, 0}), mirror);   // z = 1, facing -z
  look_down_z(ts, 10);
  EmbreeScene world(ts.scene, ts.state);
  const uint32_t w = 4, h = 3;
  const float gamma = pixel_spread_angle(ts.state.camera.fov_y, h);
  for (uint32_t bounces : {1u, 3u, 6u}) {
    SCOPED_TRACE(bounces);
    CameraPathSettings settings;
    settings.max_bounces = bounces;
    CameraPathBatch batch;
    trace_camera_paths(world, rig(ts.state.camera, w, h), 0, std::nullopt, settings, batch);
    EXPECT_EQ(batch.rays, uint64_t(w * h * bounces));
    for (uint32_t p = 0; p < w * h; ++p) {
      const CameraPathRecord& path = batch.paths[p];
      EXPECT_FALSE(ends_diffuse(path)) << p;
      EXPECT_TRUE(path.flags & PB_CAMERA_PATH_BOUNCE_LIMIT) << p;
      EXPECT_FALSE(path.flags & PB_CAMERA_PATH_ESCAPED) << p;
      // The last hit is the path's end: the S vertices before it were followed.
      EXPECT_EQ(specular_vertices(path), bounces - 1) << p;
      const glm::vec3 t = tint;
      expect_near(path.throughput,
                  {std::pow(t.x, bounces - 1.f), std::pow(t.y, bounces - 1.f),
                   std::pow(t.z, bounces - 1.f)},
                  1e-5f, "throughput", p);
      const float length = (1.f + 2.f * float(bounces - 1)) / -primary(ts, w, h, p).z;
      EXPECT_NEAR(path.cone_width, gamma * length, 1e-5f) << p;
    }
  }
  CameraPathSettings none;
  none.max_bounces = 0;
  CameraPathBatch batch;
  EXPECT_THROW(trace_camera_paths(world, rig(ts.state.camera, w, h), 0, std::nullopt, none, batch),
               InputError);
}

TEST(CameraPaths, EscapedPathsAreFlagged) {
  TestScene ts;
  ts.object(quad_mesh({-2, -2, -2}, {4, 0, 0}, {0, 4, 0}), tinted_mirror(ts, glm::vec3(1.f)));
  const CameraPathBatch batch = paths_down_z(ts, 20, 3, 3);
  for (const CameraPathRecord& path : batch.paths) {
    EXPECT_FALSE(ends_diffuse(path));
    EXPECT_TRUE(path.flags & PB_CAMERA_PATH_ESCAPED);
    EXPECT_EQ(specular_vertices(path), 1u);  // off the mirror, into nothing
    EXPECT_EQ(path.segment_length, 0.f);
  }
}

// Rough glass, so that every path draws random numbers: the paths depend on the seed and the frame
// (seed_per_frame), never on the thread count.
TEST(CameraPaths, DeterministicForASeedWhateverTheThreadCount) {
  TestScene ts;
  const uint32_t glass = ts.material(scene::MaterialType::rough_dielectric);
  ts.scene.materials[glass].roughness = 0.3f;
  ts.object(sphere_mesh({0, 0, -3}, 1.f, 32), glass);
  ts.object(box_mesh({-6, -6, -8}, {6, 6, 4}, true), ts.material(scene::MaterialType::diffuse));
  look_down_z(ts, 40);
  EmbreeScene world(ts.scene, ts.state);
  const CameraPathCamera camera = rig(ts.state.camera, 48, 32);
  auto trace = [&](uint32_t seed, uint32_t frame, int threads) {
    CameraPathSettings settings;
    settings.seed = seed;
    CameraPathBatch batch;
    tbb::task_arena arena(threads);
    arena.execute([&] { trace_camera_paths(world, camera, frame, std::nullopt, settings, batch); });
    return batch.paths;
  };
  auto same = [](const std::vector<CameraPathRecord>& a, const std::vector<CameraPathRecord>& b) {
    return a.size() == b.size() &&
           std::memcmp(a.data(), b.data(), a.size() * sizeof(CameraPathRecord)) == 0;
  };
  const auto one = trace(7, 0, 1);
  EXPECT_TRUE(same(one, trace(7, 0, 4)));
  EXPECT_FALSE(same(one, trace(8, 0, 4)));
  EXPECT_FALSE(same(one, trace(7, 1, 4)));
}

}  // namespace camera_paths_test
}  // namespace pb::trace
