// Resolving a scene at one frame: camera, lights and object transforms are pure functions of
// time = frame / fps.
#include "scene/scene.h"

#include <glm/gtc/matrix_transform.hpp>
#include <limits>

namespace pb::scene {

glm::mat4 Camera::view() const { return glm::lookAtRH(position, target, up); }

glm::mat4 Camera::projection(float aspect) const {
  // Right-handed view space (looking down -z) to Vulkan clip space: depth 0 at the near plane and 1
  // at the far plane (the _ZO variant), and y flipped because Vulkan's framebuffer y points down
  // (Vulkan spec, "Coordinate Transformations": y_f = (p_y / 2) y_d + o_y with o_y at the top).
  glm::mat4 p = glm::perspectiveRH_ZO(fov_y, aspect, near_plane, far_plane);
  p[1][1] = -p[1][1];
  return p;
}

Light LightTrack::at(float time) const {
  Light out = light;
  out.position = position.at(time);
  if (target) {
    glm::vec3 d = target->at(time) - out.position;
    float length = glm::length(d);
    if (length > 0) out.direction = d / length;  // a target on the light keeps the last direction
  }
  return out;
}

FrameState Scene::at(uint32_t frame) const {
  FrameState s;
  s.frame = frame;
  s.time = float(double(frame) / double(fps));
  const float t = s.time;
  s.camera.position = camera.position.at(t);
  s.camera.target = camera.target.at(t);
  s.camera.up = camera.up;
  s.camera.fov_y = glm::radians(camera.fov_keys.empty() ? camera.fov_y_deg : camera.fov_keys.at(t));
  s.camera.near_plane = camera.near_plane;
  s.camera.far_plane = camera.far_plane;
  s.lights.reserve(lights.size());
  for (const auto& light : lights) s.lights.push_back(light.at(t));
  s.object_to_world.reserve(objects.size());
  for (uint32_t i = 0; i < objects.size(); ++i) {
    s.object_to_world.push_back(objects[i].transform.at(t));
    if (objects[i].shape->animated()) s.deformed_objects.push_back(i);
  }
  return s;
}

Mesh Scene::mesh_at(size_t i, float time) const {
  const Object& object = objects.at(i);
  return object.shape->animated() ? object.shape->tessellate(time) : object.mesh;
}

std::pair<glm::vec3, glm::vec3> Scene::bounds() const {
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (const auto& object : objects) {
    glm::mat4 m = object.transform.at(0);
    for (const auto& p : object.mesh.positions) {
      glm::vec3 w = glm::vec3(m * glm::vec4(p, 1.0f));
      lo = glm::min(lo, w);
      hi = glm::max(hi, w);
    }
  }
  if (lo.x > hi.x) return {glm::vec3(0.0f), glm::vec3(0.0f)};
  return {lo, hi};
}

}  // namespace pb::scene
