// Resolving a scene at one frame: camera, lights and object transforms are pure functions of
// time = frame / fps.
#include "scene/scene.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <limits>

#include "photonbench/error.h"

namespace pb::scene {

namespace {

// Beyond this a coordinate is no longer traceable: Embree rejects rays with |x| > 1.8e18, and a
// hit point's offset (EmbreeScene::ray_epsilon) needs headroom. Scene files stay below
// kMaxMagnitude times their transforms' scale; only a state built elsewhere gets near this.
constexpr float kMaxTraceableCoordinate = 1e15f;

bool traceable(const glm::vec3& v) {
  for (int c = 0; c < 3; ++c)
    if (!(std::abs(v[c]) <= kMaxTraceableCoordinate)) return false;  // NaN fails too
  return true;
}

std::string when(uint32_t frame, float time) {
  return fmt::format("at frame {} (t = {:g} s)", frame, time);
}

[[noreturn]] void fail(const Scene& scene, const std::string& where, const char* what,
                       const std::string& message) {
  if (!where.empty()) throw InputError(fmt::format("{}: {}", where, message));
  throw InputError(fmt::format("{}: {}: {}", scene.file.empty() ? scene.name : scene.file.string(),
                               what, message));
}

void check_camera(const Scene& scene, const glm::vec3& position, const glm::vec3& target,
                  const glm::vec3& up, uint32_t frame, float time) {
  auto at = [&] { return when(frame, time); };
  const std::string& where = scene.camera.where;
  if (!traceable(position) || !traceable(target) || !traceable(up))
    fail(scene, where, "camera", fmt::format("{} its position, target or up is not finite", at()));
  const glm::vec3 view = target - position;
  const float distance = glm::length(view);
  if (!(distance > 1e-6f))
    fail(scene, where, "camera",
         fmt::format("{} the position ({}, {}, {}) equals the target: the camera looks nowhere",
                     at(), position.x, position.y, position.z));
  // lookAt builds the camera's x axis as cross(view, up): parallel vectors leave it undefined.
  const float sine = glm::length(glm::cross(view / distance, glm::normalize(up)));
  if (!(sine > 1e-4f))
    fail(scene, where, "camera",
         fmt::format("{} the view direction is parallel to up ({}, {}, {}): the camera has no "
                     "horizontal axis; change up or the target",
                     at(), up.x, up.y, up.z));
}

// A spot or directional light aimed by a target track at a frame where the target is on the light.
void check_light_aim(const Scene& scene, size_t i, uint32_t frame, float time) {
  const LightTrack& track = scene.lights[i];
  if (!track.target) return;
  const glm::vec3 from = track.position.at(time), to = track.target->at(time);
  if (!(glm::length(to - from) > 1e-6f))
    fail(scene, track.where, "light",
         fmt::format("{} the target ({}, {}, {}) is the light's own position: the light has no "
                     "direction",
                     when(frame, time), to.x, to.y, to.z));
}

}  // namespace

void check_frames(const Scene& scene, uint32_t first, uint32_t last) {
  for (uint64_t frame = first; frame <= last; ++frame) {
    const float t = float(double(frame) / double(scene.fps));
    check_camera(scene, scene.camera.position.at(t), scene.camera.target.at(t), scene.camera.up,
                 uint32_t(frame), t);
    for (size_t i = 0; i < scene.lights.size(); ++i) check_light_aim(scene, i, uint32_t(frame), t);
  }
}

void check_frame_state(const Scene& scene, const FrameState& state) {
  const std::string at = when(state.frame, state.time);
  check_camera(scene, state.camera.position, state.camera.target, state.camera.up, state.frame,
               state.time);
  if (!(state.camera.fov_y > 0 && state.camera.fov_y < glm::pi<float>()))
    fail(scene, scene.camera.where, "camera", at + " the field of view is not in (0, 180) degrees");
  for (size_t i = 0; i < state.lights.size(); ++i) {
    const Light& light = state.lights[i];
    const std::string where = i < scene.lights.size() ? scene.lights[i].where : "";
    const bool aimed = light.type == LightType::spot || light.type == LightType::directional;
    if (!traceable(light.position) || !traceable(light.radiant) || !traceable(light.edge_u) ||
        !traceable(light.edge_v) || !traceable(light.direction) ||
        (aimed && !(glm::length(light.direction) > 0.5f)))
      fail(scene, where, "light",
           fmt::format("{} light '{}' has a position, direction or quantity that is not finite", at,
                       light.name));
    if (i < scene.lights.size()) check_light_aim(scene, i, state.frame, state.time);
  }
  for (size_t i = 0; i < state.object_to_world.size(); ++i)
    for (int c = 0; c < 4; ++c)
      if (!traceable(glm::vec3(state.object_to_world[i][c])) ||
          !std::isfinite(state.object_to_world[i][c].w))
        throw InputError(fmt::format("{}: object '{}' {}: its transform is not finite",
                                     scene.file.string(),
                                     i < scene.objects.size() ? scene.objects[i].name : "?", at));
}

glm::mat4 Camera::view() const { return glm::lookAtRH(position, target, up); }

glm::mat4 Camera::projection(float aspect) const {
  // Right-handed view space (looking down -z) to Vulkan clip space: depth 0 at the near plane and 1
  // at the far plane (the _ZO variant), and y flipped because Vulkan's framebuffer y points down
  // (Vulkan spec, "Coordinate Transformations": y_f = (p_y / 2) y_d + o_y with o_y at the top).
  glm::mat4 p = glm::perspectiveRH_ZO(fov_y, aspect, near_plane, far_plane);
  p[1][1] = -p[1][1];
  return p;
}

float Light::area() const {
  if (type == LightType::disc) return glm::pi<float>() * glm::dot(edge_u, edge_u);
  return glm::length(glm::cross(edge_u, edge_v));
}

glm::vec3 Light::surface_point(glm::vec2 uv, glm::vec3* dp_du, glm::vec3* dp_dv) const {
  if (type != LightType::disc) {
    if (dp_du) *dp_du = edge_u, *dp_dv = edge_v;
    return position + uv.x * edge_u + uv.y * edge_v;
  }
  // Polar equal-area mapping: the area within rho is pi rho^2 radius^2 = u A.
  float rho = std::sqrt(std::max(uv.x, 0.f)), phi = 2.f * glm::pi<float>() * uv.y;
  glm::vec3 radial = std::cos(phi) * edge_u + std::sin(phi) * edge_v;
  if (dp_du) {
    *dp_du = radial * (0.5f / std::max(rho, 1e-3f));
    *dp_dv = (2.f * glm::pi<float>() * rho) * (std::cos(phi) * edge_v - std::sin(phi) * edge_u);
  }
  return position + rho * radial;
}

Light LightTrack::at(float time) const {
  Light out = light;
  out.position = position.at(time);
  if (!power.empty()) out.radiant = color * std::max(0.f, power.at(time));
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
