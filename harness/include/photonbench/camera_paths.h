// Camera paths as technique plugins see them (Context::camera_paths): from each pixel's primary ray
// (the G-buffer's camera and pixel centre) through the specular vertices the scene's BSDFs sample
// (mirror reflection, a smooth dielectric's Fresnel choice between reflection and refraction, a
// GGX-sampled rough lobe) to the first diffuse vertex: where a gather of light paths seen through
// mirrors and glass takes place (collection points, a segment walk through splats).
//
// Traced on the CPU over the World's Embree scene with the photon tracer's BSDFs (radiance
// transport), multi-threaded with oneTBB and deterministic for a given seed whatever the thread
// count: pixel p draws its random numbers from its own PCG32 stream p.
//
// Ray cones (Akenine-Möller et al. 2021, "Improved Shader and Texture Level of Detail Using Ray
// Cones", JCGT 10(1), §3): the cone starts at the eye with width 0 and the pixel's spread angle
// gamma = atan(2 tan(fov_y / 2) / height), and widens along each segment of length t by
// w += gamma t. The spread change at a vertex (their beta, from the surface curvature, and the
// roughness term of their §4) is taken as 0: exact behind flat mirrors and slabs, narrower than
// the true footprint behind curved or rough ones. So cone_width = gamma * the path's length.
#pragma once

#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

namespace pb::trace {

#include "photonbench/camera_path_layout.h"

static_assert(sizeof(CameraPathRecord) == 80, "std430 size of CameraPathRecord");
static_assert(offsetof(CameraPathRecord, position) == 0 && offsetof(CameraPathRecord, pixel) == 12);
static_assert(offsetof(CameraPathRecord, normal) == 16 &&
              offsetof(CameraPathRecord, material) == 28);
static_assert(offsetof(CameraPathRecord, throughput) == 32 &&
              offsetof(CameraPathRecord, cone_width) == 44);
static_assert(offsetof(CameraPathRecord, segment_origin) == 48 &&
              offsetof(CameraPathRecord, segment_length) == 60);
static_assert(offsetof(CameraPathRecord, segment_direction) == 64 &&
              offsetof(CameraPathRecord, flags) == 76);

struct CameraPathSettings {
  // Surface hits a path may have, its diffuse end included: a path still on a specular surface at
  // its max_bounces-th hit ends there with PB_CAMERA_PATH_BOUNCE_LIMIT. At most 255.
  uint32_t max_bounces = 6;
  uint32_t seed = 1;
  bool seed_per_frame = true;  // true: the streams are seeded with hash(seed, frame)
};

struct CameraPathBatch {
  uint32_t width = 0, height = 0;
  std::vector<CameraPathRecord> paths;  // width * height, paths[p].pixel == p
  uint64_t rays = 0;                    // segments traced
  double seconds = 0;
};

inline uint32_t specular_vertices(const CameraPathRecord& path) {
  return path.flags & PB_CAMERA_PATH_SPECULAR_MASK;
}
inline bool ends_diffuse(const CameraPathRecord& path) {
  return (path.flags & PB_CAMERA_PATH_NO_DIFFUSE) == 0;
}

}  // namespace pb::trace
