// Animation tracks. Every evaluation is a pure function of time, so frame N renders the same
// whether or not frames 0..N-1 were rendered before it (deterministic: time = frame / fps).
#include "scene/animation.h"

#include <algorithm>
#include <cmath>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>

namespace pb::scene {

namespace {

// Uniform Catmull-Rom spline through p1 (u = 0) and p2 (u = 1), tangents (p2 - p0) / 2 and (p3 -
// p1) / 2 (Catmull & Rom 1974, the tension-1/2 cardinal spline in its cubic Hermite form).
template <class T>
T catmull_rom(const T& p0, const T& p1, const T& p2, const T& p3, float u) {
  float u2 = u * u, u3 = u2 * u;
  return 0.5f * ((2.0f * p1) + (p2 - p0) * u + (2.0f * p0 - 5.0f * p1 + 4.0f * p2 - p3) * u2 +
                 (3.0f * p1 - p0 - 3.0f * p2 + p3) * u3);
}

}  // namespace

template <class T>
T Keyframes<T>::at(float time) const {
  if (times.empty()) return T{};
  const size_t n = times.size();
  if (n == 1) return values[0];
  const float first = times.front(), last = times.back();
  if (loop) {
    // One period is first..last: the last key closes the loop, so a seamless loop repeats its first
    // value.
    float period = last - first;
    float local = std::fmod(time - first, period);
    if (local < 0) local += period;
    time = first + local;
  } else {
    if (time <= first) return values.front();
    if (time >= last) return values.back();
  }
  // Segment i holds times[i] <= time < times[i + 1].
  size_t i = size_t(std::upper_bound(times.begin(), times.end(), time) - times.begin());
  i = std::clamp<size_t>(i, 1, n - 1) - 1;
  float u = (time - times[i]) / (times[i + 1] - times[i]);
  u = std::clamp(u, 0.0f, 1.0f);
  switch (interpolation) {
    case Interpolation::step:
      return values[i];
    case Interpolation::linear:
      return values[i] + (values[i + 1] - values[i]) * u;
    case Interpolation::catmull_rom: {
      // Neighbours beyond the ends: a clamped track repeats its end value (so the end tangent is
      // half the chord to the next key); a loop takes them from the other end of the cycle, whose
      // keys are 0..n-2 (key n-1 is key 0 again).
      const T& p0 = i > 0 ? values[i - 1] : (loop ? values[n - 2] : values[0]);
      const T& p3 =
          i + 2 < n ? values[i + 2] : (loop ? values[std::min<size_t>(1, n - 1)] : values[n - 1]);
      return catmull_rom(p0, values[i], values[i + 1], p3, u);
    }
  }
  return values[i];
}

template struct Keyframes<float>;
template struct Keyframes<glm::vec3>;

glm::vec3 Orbit::at(float time) const {
  // Counter-clockwise seen from above (+y) is a positive rotation about +y: +x turns towards -z.
  float angle = phase + glm::two_pi<float>() * time / period;
  return center + glm::vec3(radius * std::cos(angle), height, -radius * std::sin(angle));
}

glm::vec3 PositionTrack::at(float time) const {
  if (orbit) return orbit->at(time);
  if (!keys.empty()) return keys.at(time);
  return constant;
}

glm::mat4 TransformTrack::at(float time) const {
  glm::vec3 euler = rotation_deg + spin_deg_per_s * time;
  if (!rotation_keys.empty()) euler += rotation_keys.at(time);
  glm::vec3 s = scale;
  if (!scale_keys.empty()) s *= scale_keys.at(time);
  // XYZ Euler: rotate about x first, then y, then z (R = Rz Ry Rx); object -> world = T R S.
  glm::mat4 m = glm::translate(glm::mat4(1.0f), translation.at(time));
  m = glm::rotate(m, glm::radians(euler.z), glm::vec3(0, 0, 1));
  m = glm::rotate(m, glm::radians(euler.y), glm::vec3(0, 1, 0));
  m = glm::rotate(m, glm::radians(euler.x), glm::vec3(1, 0, 0));
  return glm::scale(m, s);
}

bool TransformTrack::animated() const {
  return translation.animated() || !rotation_keys.empty() || !scale_keys.empty() ||
         spin_deg_per_s != glm::vec3(0.0f);
}

}  // namespace pb::scene
