// collection-points' CPU side, shared by the plugin and its tests: the collection points of one
// frame's camera paths (Paper V §3: position, radius, box) and the photons as the accumulation
// reads them.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
#include <span>
#include <vector>

#include "photonbench/camera_paths.h"
#include "photonbench/photons.h"
#include "photonbench/scene_triangles.h"
#include "photonbench/toolkit/box_bvh.h"

namespace cp {

#include "cp_layout.h"

using glm::dot;
using std::abs;
using std::exp;
#include "cp_gather.h"

static_assert(sizeof(CpPoint) == 64 && offsetof(CpPoint, normal) == 16 &&
              offsetof(CpPoint, throughput) == 32 && offsetof(CpPoint, specular) == 60);
static_assert(sizeof(CpPhoton) == 48 && offsetof(CpPhoton, power) == 16 &&
              offsetof(CpPhoton, normal) == 32);

// The radius cap at `width` pixels: `cap_at_1080p` (Paper V: 5 mm at 1920 x 1080) times 1920 /
// width, so that a cap spans the same number of pixels at every resolution.
inline float radius_cap(float cap_at_1080p, uint32_t width) {
  return cap_at_1080p * 1920.0f / float(width);
}

// The radius from the pixel's ray cone at the CP (Paper V §3, the authors' code): half the cone's
// width over max(1e-3, |n . v|), then capped.
inline float footprint_radius(const pb::trace::CameraPathRecord& path, float cap) {
  const float cosine = std::abs(glm::dot(path.normal, path.segment_direction));
  return std::min(0.5f * path.cone_width / std::max(1e-3f, cosine), cap);
}

struct PointSet {
  std::vector<CpPoint> points;
  std::vector<pb::toolkit::BvhBox> boxes;  // the cylinders' boxes
  std::vector<uint32_t> point_of_pixel;    // CP_NONE where the path ended on no diffuse vertex
  uint32_t count = 0;                      // CPs (points also holds empty slots when per pixel)
  uint32_t behind_specular = 0;            // CPs with at least one S vertex before them
  uint32_t capped = 0;                     // radii cut to the cap
  double radius_sum = 0;
};

// One CP per camera path that ends on a diffuse vertex (its first), with a cylinder of radius r
// and height r / 10 (Paper V §3) and that cylinder's box. Packed, the CPs follow one another;
// `per_pixel`, CP i is pixel i's, and a pixel without one holds an empty slot (material CP_NONE,
// radius 0, an empty box): the same item for the same pixel every frame, which a refit of the
// BVH needs (the paper's one box per pixel, inactive where the pixel has no CP).
void make_points(std::span<const pb::trace::CameraPathRecord> paths, float cap, PointSet& out,
                 bool per_pixel = false);

// The stored photons with the material of the triangle each landed on (CP_NONE without one).
void make_photons(std::span<const pb::trace::PhotonRecord> photons, const pb::SceneTriangles& scene,
                  std::vector<CpPhoton>& out);

}  // namespace cp
