// What the reference renderer's estimators share (path_tracing_pass.cpp, bdpt.cpp,
// photon_mapping_pass.cpp): the camera rig, the classification of a full path into its
// path class (reference.h), and the rule that splits path space between the unbiased estimators
// and photon mapping. Internal to reference/.
#pragma once

#include <algorithm>
#include <cmath>
#include <glm/glm.hpp>
#include <limits>
#include <optional>

#include "reference/estimators.h"
#include "reference/path_class.h"
#include "scene/scene.h"
#include "trace/embree_scene.h"

namespace pb::trace::detail {

inline constexpr int kClasses = 5;  // the partition; `combined` is their sum

inline float luminance(const glm::vec3& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }
inline float max3(const glm::vec3& v) { return std::max(v.x, std::max(v.y, v.z)); }

inline float power_heuristic(float a, float b) {
  float a2 = a * a, b2 = b * b;
  return a2 + b2 > 0 ? a2 / (a2 + b2) : 0.f;
}

// A full path's light path expression read from the camera, reduced to what decides its class (see
// reference.h): the first vertex's type, whether a diffuse "anchor" vertex exists (the first vertex
// if diffuse, else the first diffuse one after the specular prefix), and which types follow the
// anchor. Whichever strategy produced a path, pushing its scattering vertices from the camera side
// in order and calling classify() gives its class, so every estimator partitions path space alike.
// (Its members are always inlined: every camera-path vertex asks them, inside loops too large for
// GCC to inline them on its own.)
struct ClassState {
  uint8_t first = 0;  // 0 none, 1 D, 2 S
  bool anchor = false, d_after = false, s_after = false;
  [[gnu::always_inline]] ClassState push(bool diffuse) const {
    ClassState s = *this;
    if (s.first == 0) {
      s.first = diffuse ? 1 : 2;
      s.anchor = diffuse;
    } else if (!s.anchor) {
      s.anchor = diffuse;
    } else if (diffuse) {
      s.d_after = true;
    } else {
      s.s_after = true;
    }
    return s;
  }
  // Class of the path ending at an emitter now.
  [[gnu::always_inline]] int classify() const {
    if (first == 0) return int(PathClass::direct);
    if (first == 1) {
      if (d_after) return int(PathClass::indirect);
      return s_after ? int(PathClass::caustics) : int(PathClass::direct);
    }
    if (anchor && s_after && !d_after) return int(PathClass::indirect_caustics);
    return int(PathClass::specular);
  }
  // Classes some continuation of this path can still end in.
  [[gnu::always_inline]] uint32_t reachable() const {
    auto bit = [](PathClass c) { return class_bit(c); };
    if (first == 0) return kAllPathClasses;
    if (first == 1) {
      if (d_after) return bit(PathClass::indirect);
      if (s_after) return bit(PathClass::caustics) | bit(PathClass::indirect);
      return bit(PathClass::direct) | bit(PathClass::caustics) | bit(PathClass::indirect);
    }
    if (anchor && d_after) return bit(PathClass::specular);
    return bit(PathClass::specular) | bit(PathClass::indirect_caustics);
  }
};

// The split of path space between the unbiased estimators and photon mapping: photon mapping owns
// exactly the paths with a diffuse vertex whose vertex next to the emitter is specular (L S ... D
// ...): `anchored` is "a diffuse vertex exists" (ClassState::anchor) and `light_side_specular` the
// type of the scattering vertex next to the emitter.
inline bool photon_mapping_owns(bool anchored, bool light_side_specular) {
  return anchored && light_side_specular;
}

// The pinhole camera of scene::Camera (glm::lookAtRH's basis, vertical fov, y down in pixels).
struct Rig {
  glm::vec3 position, right, up, forward;
  float tan_half, aspect;
  int width, height;
  Rig(const scene::Camera& c, int w, int h) : width(w), height(h) {
    position = c.position;
    forward = glm::normalize(c.target - c.position);
    right = glm::normalize(glm::cross(forward, c.up));  // glm::lookAtRH's basis
    up = glm::cross(right, forward);
    tan_half = std::tan(0.5f * c.fov_y);
    aspect = float(w) / float(h);
  }
  glm::vec3 direction(float px, float py) const {
    float x = (2.f * px / width - 1.f) * tan_half * aspect;
    float y = (1.f - 2.f * py / height) * tan_half;  // Vulkan clip y points down: row 0 is the top
    return glm::normalize(forward + x * right + y * up);
  }
  // The pixel position a world direction from the camera lands on; false outside the image.
  bool raster(const glm::vec3& dir, glm::vec2& px) const {
    float z = glm::dot(dir, forward);
    if (z <= 0) return false;
    float x = glm::dot(dir, right) / (z * tan_half * aspect);
    float y = glm::dot(dir, up) / (z * tan_half);
    px = {(x + 1.f) * 0.5f * width, (1.f - y) * 0.5f * height};
    return px.x >= 0 && px.y >= 0 && px.x < width && px.y < height;
  }
  // The solid-angle density of camera directions whose image-plane position is uniform over the
  // whole image: 1 / (A cos^3 theta), A the image's area on the plane at distance 1 (an image-plane
  // area element at angle theta subtends cos^3 theta / 1 of solid angle). It is also the camera's
  // importance W_e normalised over the image (Veach 1997 §10.1, for box-filtered pixels): a light
  // path's connection to the camera adds f W_e cos / d^2 to the pixel it lands in, and one light
  // path per pixel makes each such splat an estimate of that pixel's mean radiance.
  float film_density(const glm::vec3& dir) const {
    float c = glm::dot(dir, forward);
    if (c <= 0) return 0;
    float film_area = (2.f * tan_half * aspect) * (2.f * tan_half);
    return 1.f / (film_area * c * c * c);
  }
};

// The pixels a pilot of Estimator::automatic renders: a grid of every stride-th pixel in x and y
// (every pixel for stride 1).
inline bool in_grid(int x, int y, int stride) {
  return stride <= 1 || (x % stride == stride / 2 && y % stride == stride / 2);
}

// A ray origin off the surface on the side `dir` leaves towards.
[[gnu::always_inline]] inline glm::vec3 offset_origin(const Hit& hit, const glm::vec3& dir) {
  float eps = EmbreeScene::ray_epsilon(hit.position);
  return hit.position +
         hit.geometric_normal * (glm::dot(dir, hit.geometric_normal) >= 0 ? eps : -eps);
}

// Is the segment from surface point `from` to `target` free of occluders? The ray leaves from the
// offset origin, is aimed at `target` from there, and stops ray_epsilon(target) short of it. (Aimed
// from the unshifted point with the unshifted length instead, the shadow ray of a sample on an area
// light reaches that light's own plane inside its range whenever the offset along the normal
// outruns the 1e-4 relative shortening, and the light's geometry shadows its own sample: quad
// lights a few centimetres from a surface read 0.1-0.8 of the closed form there: README
// "Near-field area lights".)
// shadow_ray() is that ray, or none where the target lies within the offset (then the segment
// counts as clear); a target at infinity (`infinite`: a directional light) is the direction
// `target`.
[[gnu::always_inline]] inline std::optional<Ray> shadow_ray(const Hit& from,
                                                            const glm::vec3& target,
                                                            bool infinite) {
  if (infinite) return Ray{offset_origin(from, target), target, kUnboundedRay};
  glm::vec3 origin = offset_origin(from, target - from.position);
  glm::vec3 d = target - origin;
  float length = glm::length(d);
  float tmax = length - EmbreeScene::ray_epsilon(target);
  if (!(tmax > 0)) return std::nullopt;
  return Ray{origin, d * (1.f / length), tmax};
}
inline bool segment_clear(const EmbreeScene& world, const Hit& from, const glm::vec3& target) {
  std::optional<Ray> ray = shadow_ray(from, target, false);
  return !ray || !world.occluded(ray->origin, ray->dir, ray->tmax);
}

// Is the way from `from` along `dir` to infinity free (a directional light)?
inline bool direction_clear(const EmbreeScene& world, const Hit& from, const glm::vec3& dir) {
  std::optional<Ray> ray = shadow_ray(from, dir, true);
  return !world.occluded(ray->origin, ray->dir, ray->tmax);
}

// The full-path scattering-vertex budget (reference.h, max_bounces) as a count; 0 there means
// untruncated, capped here so that paths stay finite.
inline uint32_t bounce_budget(uint32_t max_bounces) {
  return max_bounces == 0 ? kUntruncatedBounces : std::min(max_bounces, kUntruncatedBounces);
}

}  // namespace pb::trace::detail
