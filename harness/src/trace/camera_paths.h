// The camera-path tracer behind Context::camera_paths (photonbench/camera_paths.h): one path per
// pixel over an EmbreeScene, with the photon tracer's BSDFs (bsdf.h) in radiance transport.
#pragma once

#include <cstdint>
#include <glm/glm.hpp>
#include <optional>

#include "photonbench/camera_paths.h"
#include "trace/embree_scene.h"

namespace pb::trace {

// The camera the G-buffer was rasterised with: primary rays leave `eye` through each pixel's centre
// as `inverse_view_projection` maps it (Vulkan clip space: depth 0 near, row 0 at the top).
struct CameraPathCamera {
  glm::vec3 eye{0.0f};
  glm::mat4 inverse_view_projection{1.0f};
  float fov_y = 1;  // radians, vertical: the cone's spread angle
  uint32_t width = 0, height = 0;
};

// The cone's spread angle per pixel, gamma_0 of Akenine-Möller et al. 2021 §3.
float pixel_spread_angle(float fov_y, uint32_t height);

// Traces one path per pixel of `camera` into `out` (resized to width * height). `frame` seeds the
// streams with settings.seed_per_frame; `seed_scramble` (a seed axis' cell) is hashed into the
// seed as the photon tracer does. Throws pb::InputError for max_bounces outside [1, 255].
void trace_camera_paths(const EmbreeScene& world, const CameraPathCamera& camera, uint32_t frame,
                        std::optional<uint32_t> seed_scramble, const CameraPathSettings& settings,
                        CameraPathBatch& out);

}  // namespace pb::trace
