// Animation tracks: keyframes with step, linear or Catmull-Rom interpolation, or an orbit. Every
// track is a pure function of time, so a frame is reproducible on its own (time = frame / fps).
#pragma once

#include <glm/glm.hpp>
#include <optional>
#include <string>
#include <vector>

namespace pb::scene {

enum class Interpolation { step, linear, catmull_rom };

// Time outside the keys holds the first / last value, or wraps when `loop` is set.
template <class T>
struct Keyframes {
  std::vector<float> times;  // seconds, strictly increasing
  std::vector<T> values;
  Interpolation interpolation = Interpolation::linear;
  bool loop = false;
  bool empty() const { return times.empty(); }
  T at(float time) const;
};

// A circle around `center` in the plane at `center.y + height`, `period` seconds per turn,
// starting at `phase_deg` (0 = +x axis), counter-clockwise seen from above.
struct Orbit {
  glm::vec3 center{0.0f};
  float radius = 1.f;
  float height = 0.f;
  float period = 4.f;
  float phase = 0.f;  // radians
  glm::vec3 at(float time) const;
};

// A position that is constant, keyframed, or orbiting.
struct PositionTrack {
  glm::vec3 constant{0.0f};
  Keyframes<glm::vec3> keys;
  std::optional<Orbit> orbit;
  glm::vec3 at(float time) const;
  bool animated() const { return !keys.empty() || orbit.has_value(); }
};

struct TransformTrack {
  PositionTrack translation;
  glm::vec3 rotation_deg{0.0f};        // XYZ Euler, constant part
  Keyframes<glm::vec3> rotation_keys;  // XYZ Euler degrees over time
  glm::vec3 spin_deg_per_s{0.0f};      // constant angular velocity, added to the rotation
  glm::vec3 scale{1.0f};
  Keyframes<glm::vec3> scale_keys;
  glm::mat4 at(float time) const;
  bool animated() const;
};

struct CameraTrack {
  PositionTrack position;
  PositionTrack target;
  glm::vec3 up{0, 1, 0};
  float fov_y_deg = 45.f;
  Keyframes<float> fov_keys;
  float near_plane = 0.01f, far_plane = 100.f;
  std::string where;  // "file:line:col: camera", for errors about the camera at some frame
};

}  // namespace pb::scene
