// AAPS's study scenes (configs/aaps.yaml): AAPS splats its caustic photons onto the
// receiver the G-buffer holds, so its MSAA modes can only be compared where the caustic's
// receiver is seen directly. Measured on the CPU, over the study's 320x160 camera rays at its
// measured frames (12-19): the share of pixels whose camera ray first meets a diffuse surface
// from which the segment towards the light first meets a dielectric (a receiver of L S+ D light,
// seen directly: E D S+ L). `pool` (camera above the water, under the sun) is the negative
// control: there the caustic lies under the water and is seen only through it.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <glm/glm.hpp>
#include <utility>

#include "scene/scene.h"
#include "trace/embree_scene.h"

namespace pb::aaps_scenes_test {

struct Shares {
  double direct_caustic_receiver = 0;  // diffuse first hit, lit through a dielectric
  double through_dielectric = 0;       // the camera ray's first hit is a dielectric
};

Shares measure(const std::string& name) {
  scene::Scene s = scene::load_scene(scene::find_scene(name, {}));
  constexpr uint32_t kWidth = 320, kHeight = 160, kFirst = 12, kLast = 19;
  uint64_t receivers = 0, through = 0, rays = 0;
  scene::FrameState state = s.at(kFirst);
  trace::EmbreeScene world(s, state);
  for (uint32_t frame = kFirst; frame <= kLast; ++frame) {
    state = s.at(frame);
    world.update(state);
    const scene::Camera& camera = state.camera;
    glm::mat4 inverse =
        glm::inverse(camera.projection(float(kWidth) / float(kHeight)) * camera.view());
    for (uint32_t y = 0; y < kHeight; ++y)
      for (uint32_t x = 0; x < kWidth; ++x) {
        ++rays;
        glm::vec2 ndc((float(x) + 0.5f) / float(kWidth) * 2.f - 1.f,
                      (float(y) + 0.5f) / float(kHeight) * 2.f - 1.f);
        glm::vec4 far = inverse * glm::vec4(ndc, 1.f, 1.f);
        glm::vec3 dir = glm::normalize(glm::vec3(far) / far.w - camera.position);
        trace::Hit hit;
        if (!world.intersect(camera.position, dir, trace::kUnboundedRay, hit) ||
            world.is_light_object(hit.object))
          continue;
        const scene::Material& m = s.materials[hit.material];
        if (m.type == scene::MaterialType::dielectric) {
          ++through;
          continue;
        }
        if (m.type != scene::MaterialType::diffuse) continue;
        for (const scene::Light& light : state.lights) {
          glm::vec3 to_light;
          float tmax = trace::kUnboundedRay;
          if (light.type == scene::LightType::directional) {
            to_light = -light.direction;
          } else if (light.type == scene::LightType::point ||
                     light.type == scene::LightType::spot) {
            to_light = light.position - hit.position;
            tmax = 1.f;
          } else {
            continue;
          }
          glm::vec3 n = glm::dot(hit.geometric_normal, to_light) > 0 ? hit.geometric_normal
                                                                     : -hit.geometric_normal;
          glm::vec3 origin = hit.position + n * trace::EmbreeScene::ray_epsilon(hit.position);
          trace::Hit blocker;
          if (world.intersect(origin, to_light, tmax, blocker) &&
              !world.is_light_object(blocker.object) &&
              s.materials[blocker.material].type == scene::MaterialType::dielectric) {
            ++receivers;
            break;
          }
        }
      }
  }
  return {double(receivers) / double(rays), double(through) / double(rays)};
}

TEST(AapsScenes, CausticReceiversAreSeenDirectly) {
  Shares pool = measure("pool"), underwater = measure("pool-underwater"),
         square = measure("square");
  const std::pair<const char*, Shares> all[] = {
      {"pool", pool}, {"pool-underwater", underwater}, {"square", square}};
  for (const auto& [name, v] : all)
    std::printf("%s: caustic receivers seen directly %.4f, seen through a dielectric %.4f\n", name,
                v.direct_caustic_receiver, v.through_dielectric);
  // Above the water the pool's caustic receivers are seen through the water surface only.
  EXPECT_LT(pool.direct_caustic_receiver, 0.01) << pool.through_dielectric;
  EXPECT_GT(pool.through_dielectric, 0.3);
  // Under it, the floor and walls the water lights fill most of the frame.
  EXPECT_GT(underwater.direct_caustic_receiver, 0.6) << underwater.through_dielectric;
  // Square: the light reaches a patch of the square behind each glass object through it.
  EXPECT_GT(square.direct_caustic_receiver, 0.015) << square.through_dielectric;
}

TEST(AapsScenes, OnePointLightAndGlassOfIor15) {
  // The thesis's scenes (seed 004 §4.1): one point light each, every dielectric of ior 1.5.
  for (const char* name : {"pool-underwater", "square"}) {
    SCOPED_TRACE(name);
    scene::Scene s = scene::load_scene(scene::find_scene(name, {}));
    ASSERT_EQ(s.lights.size(), 1u);
    EXPECT_EQ(s.lights[0].light.type, scene::LightType::point);
    for (const scene::Material& m : s.materials)
      if (m.type == scene::MaterialType::dielectric) EXPECT_FLOAT_EQ(m.ior, 1.5f) << m.name;
  }
}

}  // namespace pb::aaps_scenes_test
