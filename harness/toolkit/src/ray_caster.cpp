#include "photonbench/toolkit/ray_caster.h"

#include <embree3/rtcore.h>

#include <limits>

#include "photonbench/error.h"

namespace pb::toolkit {

struct TriangleRayCaster::State {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  ~State() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

TriangleRayCaster::TriangleRayCaster(const SceneTriangles& triangles)
    : state_(std::make_unique<State>()) {
  state_->device = rtcNewDevice(nullptr);
  if (!state_->device) throw Error("TriangleRayCaster: Embree could not make a device");
  state_->scene = rtcNewScene(state_->device);
  // One geometry of every triangle, so Embree's primitive id is the scene-wide triangle index.
  RTCGeometry geometry = rtcNewGeometry(state_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  const size_t vertices = std::max<size_t>(1, triangles.host_vertices.size());
  auto* positions = static_cast<float*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), vertices));
  for (size_t v = 0; v < triangles.host_vertices.size(); ++v)
    for (int c = 0; c < 3; ++c) positions[3 * v + c] = triangles.host_vertices[v].position[c];
  auto* indices = static_cast<uint32_t*>(
      rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                              3 * sizeof(uint32_t), triangles.host_triangles.size()));
  for (size_t t = 0; t < triangles.host_triangles.size(); ++t)
    for (int c = 0; c < 3; ++c) indices[3 * t + c] = triangles.host_triangles[t].vertices_object[c];
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(state_->scene, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(state_->scene);
}

TriangleRayCaster::~TriangleRayCaster() = default;

std::optional<TriangleRayCaster::Hit> TriangleRayCaster::closest(glm::vec3 origin,
                                                                 glm::vec3 direction, float t_min,
                                                                 float t_max) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh{};
  rh.ray.org_x = origin.x;
  rh.ray.org_y = origin.y;
  rh.ray.org_z = origin.z;
  rh.ray.dir_x = direction.x;
  rh.ray.dir_y = direction.y;
  rh.ray.dir_z = direction.z;
  rh.ray.tnear = t_min;
  rh.ray.tfar = t_max;
  rh.ray.mask = std::numeric_limits<unsigned>::max();
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(state_->scene, &context, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
  return Hit{rh.hit.primID, rh.ray.tfar};
}

}  // namespace pb::toolkit
