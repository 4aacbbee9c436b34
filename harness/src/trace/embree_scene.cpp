#include "trace/embree_scene.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <type_traits>

#include "photonbench/error.h"
#include "scene/world_triangles.h"

namespace pb::trace {
namespace {

void report_embree_error(void*, RTCError code, const char* message) {
  // Embree reports through this callback; a failed build then shows up as missing geometry, so say
  // it.
  std::fprintf(stderr, "embree error %d: %s\n", int(code), message ? message : "");
}

Aabb transform_bounds(const Aabb& local, const glm::mat4& m) {
  Aabb out;
  if (local.empty()) return out;
  for (int c = 0; c < 8; ++c) {
    glm::vec3 p{(c & 1) ? local.hi.x : local.lo.x, (c & 2) ? local.hi.y : local.lo.y,
                (c & 4) ? local.hi.z : local.lo.z};
    out.extend(glm::vec3(m * glm::vec4(p, 1.f)));
  }
  return out;
}

bool same_light_geometry(const scene::Light& a, const scene::Light& b) {
  return a.type == b.type && a.position == b.position && a.edge_u == b.edge_u &&
         a.edge_v == b.edge_v;
}

}  // namespace

bool Aabb::intersects(const glm::vec3& origin, const glm::vec3& dir, float tmax) const {
  float t0 = 0, t1 = tmax;
  for (int a = 0; a < 3; ++a) {
    float inv = 1.f / dir[a];  // +-inf for an axis-parallel ray: the comparisons below still hold
    float ta = (lo[a] - origin[a]) * inv, tb = (hi[a] - origin[a]) * inv;
    if (ta > tb) std::swap(ta, tb);
    if (std::isnan(ta) || std::isnan(tb)) {  // origin on a slab plane of a parallel ray
      if (origin[a] < lo[a] || origin[a] > hi[a]) return false;
      continue;
    }
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1 * (1 + 4e-6f) + 1e-7f) return false;
  }
  return true;
}

RTCDevice EmbreeScene::device() {
  static RTCDevice device = [] {
    RTCDevice d = rtcNewDevice(nullptr);
    if (!d)
      throw Error(fmt::format("embree: cannot create a device (error {})",
                              int(rtcGetDeviceError(nullptr))));
    rtcSetDeviceErrorFunction(d, report_embree_error, nullptr);
    return d;
  }();
  return device;
}

EmbreeScene::EmbreeScene(const scene::Scene& scene, const scene::FrameState& state,
                         EmbreeOptions options)
    : scene_(scene),
      state_(state),
      options_(options),
      first_triangle_(scene::first_triangles(scene)) {
  // Embree aborts the process on a ray it cannot trace (NaN or huge coordinates): a frame whose
  // camera or lights are degenerate is bad input, named where the scene file sets it.
  scene::check_frame_state(scene, state);
  RTCDevice dev = device();
  top_ = rtcNewScene(dev);
  rtcSetSceneFlags(top_, RTC_SCENE_FLAG_DYNAMIC);
  rtcSetSceneBuildQuality(top_, RTC_BUILD_QUALITY_MEDIUM);
  objects_.resize(scene.objects.size());
  for (uint32_t i = 0; i < objects_.size(); ++i) {
    const scene::Object& object = scene.objects[i];
    ObjectData& data = objects_[i];
    bool deforms = object.shape && object.shape->animated();
    if (!object.shape && object.mesh.triangles.empty())
      throw InputError(fmt::format("object '{}' has neither a shape nor a mesh", object.name));
    data.mesh = &object.mesh;
    if (deforms || object.mesh.triangles.empty()) {  // a deforming shape: its mesh at this frame
      data.deformed = std::make_unique<scene::Mesh>(object.shape->tessellate(state.time));
      data.mesh = data.deformed.get();
    }
    const scene::Mesh& mesh = *data.mesh;
    if (mesh.triangles.empty())
      throw InputError(fmt::format("object '{}' has no triangles", object.name));
    data.flattened = !deforms && (object.transform.animated() ? options_.flatten_moving
                                                              : options_.flatten_static);
    data.geometry = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(data.geometry,
                               deforms ? RTC_BUILD_QUALITY_REFIT : RTC_BUILD_QUALITY_HIGH);
    auto* index = static_cast<glm::uvec3*>(
        rtcSetNewGeometryBuffer(data.geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                sizeof(glm::uvec3), mesh.triangles.size()));
    std::memcpy(index, mesh.triangles.data(), mesh.triangles.size() * sizeof(glm::uvec3));
    rtcSetNewGeometryBuffer(data.geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                            sizeof(glm::vec3), mesh.positions.size());
    data.local_bounds = Aabb{};
    for (const auto& p : mesh.positions) data.local_bounds.extend(p);
    glm::mat4 to_world =
        i < state.object_to_world.size() ? state.object_to_world[i] : glm::mat4(1.0f);
    if (data.flattened) {
      rtcAttachGeometryByID(top_, data.geometry, i);
      place_object(i, to_world);  // writes the world-space vertices
    } else {
      data.scene = rtcNewScene(dev);
      // REFIT is a geometry's build quality only (for a scene Embree reports "invalid build
      // quality" and keeps its default, MEDIUM): a deforming object's scene stays MEDIUM, and its
      // geometry refits.
      rtcSetSceneBuildQuality(data.scene,
                              deforms ? RTC_BUILD_QUALITY_MEDIUM : RTC_BUILD_QUALITY_HIGH);
      if (deforms) rtcSetSceneFlags(data.scene, RTC_SCENE_FLAG_DYNAMIC);
      set_vertices(data, mesh);
      rtcAttachGeometry(data.scene, data.geometry);
      rtcCommitScene(data.scene);
      data.instance = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_INSTANCE);
      rtcSetGeometryInstancedScene(data.instance, data.scene);
      place_object(i, to_world);
      rtcAttachGeometryByID(top_, data.instance, i);
    }
  }
  light_geometry_.assign(state.lights.size(), nullptr);
  place_lights();
  rtcCommitScene(top_);
}

EmbreeScene::~EmbreeScene() {
  for (auto& data : objects_) {
    if (data.instance) rtcReleaseGeometry(data.instance);
    if (data.geometry) rtcReleaseGeometry(data.geometry);
    if (data.scene) rtcReleaseScene(data.scene);
  }
  for (RTCGeometry g : light_geometry_)
    if (g) rtcReleaseGeometry(g);
  if (top_) rtcReleaseScene(top_);
}

void EmbreeScene::set_vertices(ObjectData& data, const scene::Mesh& mesh) {
  auto* vertices =
      static_cast<glm::vec3*>(rtcGetGeometryBufferData(data.geometry, RTC_BUFFER_TYPE_VERTEX, 0));
  std::memcpy(vertices, mesh.positions.data(), mesh.positions.size() * sizeof(glm::vec3));
  data.geometry_mesh = &mesh;
  // Each triangle's unit normal, oriented as its vertex normals (if any) where they all agree; a
  // triangle whose vertex normals all lie along it is flat, and a hit on it needs no interpolation.
  const bool normals = mesh.normals.size() == mesh.positions.size();
  data.triangle_normals.resize(mesh.triangles.size());
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const glm::uvec3 tri = mesh.triangles[t];
    const glm::vec3 p0 = mesh.positions[tri.x];
    glm::vec3 face = glm::cross(mesh.positions[tri.y] - p0, mesh.positions[tri.z] - p0);
    float len = glm::length(face);
    TriangleNormal& tn = data.triangle_normals[t];
    tn.face = len > 0 ? face / len : glm::vec3(0, 1, 0);
    tn.flat = !normals;
    if (!normals || !(len > 0)) continue;
    float along[3];
    for (int k = 0; k < 3; ++k) {
      glm::vec3 n = mesh.normals[tri[k]];
      float nl = glm::length(n);
      along[k] = nl > 0 ? glm::dot(n, tn.face) / nl : 0.f;
    }
    auto parallel = [](float a) { return std::abs(a) >= 1.f - 1e-6f; };
    bool same_side = (along[0] > 0) == (along[1] > 0) && (along[1] > 0) == (along[2] > 0);
    tn.flat = parallel(along[0]) && parallel(along[1]) && parallel(along[2]) && same_side;
    if (tn.flat && along[0] < 0) tn.face = -tn.face;
  }
  rtcUpdateGeometryBuffer(data.geometry, RTC_BUFFER_TYPE_VERTEX, 0);
  rtcCommitGeometry(data.geometry);
}

void EmbreeScene::place_object(uint32_t i, const glm::mat4& to_world) {
  ObjectData& data = objects_[i];
  data.to_world = to_world;
  if (data.flattened) {
    const scene::Mesh& mesh = *data.mesh;
    glm::mat3 nm = glm::transpose(glm::inverse(glm::mat3(to_world)));
    data.world_mesh.positions.resize(mesh.positions.size());
    data.world_mesh.normals.resize(mesh.normals.size());
    data.world_mesh.triangles = mesh.triangles;
    data.bounds = Aabb{};
    for (size_t v = 0; v < mesh.positions.size(); ++v) {
      data.world_mesh.positions[v] = glm::vec3(to_world * glm::vec4(mesh.positions[v], 1.f));
      data.bounds.extend(data.world_mesh.positions[v]);
    }
    for (size_t v = 0; v < mesh.normals.size(); ++v)
      data.world_mesh.normals[v] = nm * mesh.normals[v];
    data.geometry_to_world = glm::mat4(1.0f);
    data.normal_to_world = glm::mat3(1.0f);
    set_vertices(data, data.world_mesh);
    return;
  }
  data.geometry_to_world = to_world;
  data.normal_to_world = glm::transpose(glm::inverse(glm::mat3(to_world)));
  // The transformed triangle's edge cross product is det(M) M^-T (e1 x e2): a mirroring transform
  // turns the winding, and the geometric normal with it.
  data.winding = glm::determinant(glm::mat3(to_world)) < 0 ? -1.f : 1.f;
  data.bounds = transform_bounds(data.local_bounds, to_world);
  rtcSetGeometryTransform(data.instance, 0, RTC_FORMAT_FLOAT4X4_COLUMN_MAJOR, &data.to_world[0][0]);
  rtcCommitGeometry(data.instance);
}

void EmbreeScene::place_lights() {
  if (!options_.area_lights_as_geometry) return;
  RTCDevice dev = device();
  for (uint32_t l = 0; l < state_.lights.size(); ++l) {
    const scene::Light& light = state_.lights[l];
    RTCGeometry& g = light_geometry_[l];
    if (light.type == scene::LightType::disc) {
      // Embree's oriented disc: the exact circle, so a hit and a light sample see the same area.
      if (!g) {
        g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_ORIENTED_DISC_POINT);
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, sizeof(glm::vec4),
                                1);
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_NORMAL, 0, RTC_FORMAT_FLOAT3, sizeof(glm::vec3),
                                1);
        rtcAttachGeometryByID(top_, g, light_object(l));
      }
      *static_cast<glm::vec4*>(rtcGetGeometryBufferData(g, RTC_BUFFER_TYPE_VERTEX, 0)) =
          glm::vec4(light.position, glm::length(light.edge_u));
      *static_cast<glm::vec3*>(rtcGetGeometryBufferData(g, RTC_BUFFER_TYPE_NORMAL, 0)) =
          light.normal();
      rtcUpdateGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0);
      rtcUpdateGeometryBuffer(g, RTC_BUFFER_TYPE_NORMAL, 0);
      rtcCommitGeometry(g);
      continue;
    }
    if (light.type != scene::LightType::quad) continue;
    if (!g) {
      g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
      auto* index = static_cast<glm::uvec3*>(rtcSetNewGeometryBuffer(
          g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, sizeof(glm::uvec3), 2));
      index[0] = {0, 1, 2};
      index[1] = {0, 2, 3};
      rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, sizeof(glm::vec3),
                              4);
      rtcAttachGeometryByID(top_, g, light_object(l));
    }
    auto* v = static_cast<glm::vec3*>(rtcGetGeometryBufferData(g, RTC_BUFFER_TYPE_VERTEX, 0));
    v[0] = light.position;
    v[1] = light.position + light.edge_u;
    v[2] = light.position + light.edge_u + light.edge_v;
    v[3] = light.position + light.edge_v;
    rtcUpdateGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0);
    rtcCommitGeometry(g);
  }
}

void EmbreeScene::update(const scene::FrameState& state) {
  scene::check_frame_state(scene_, state);
  if (state.lights.size() != state_.lights.size())
    throw Error("EmbreeScene::update: the number of lights changed");
  for (uint32_t i = 0; i < objects_.size(); ++i) {
    ObjectData& data = objects_[i];
    bool deformed = std::find(state.deformed_objects.begin(), state.deformed_objects.end(), i) !=
                    state.deformed_objects.end();
    if (deformed && scene_.objects[i].shape && scene_.objects[i].shape->animated()) {
      auto mesh = std::make_unique<scene::Mesh>(scene_.objects[i].shape->tessellate(state.time));
      if (mesh->positions.size() != data.mesh->positions.size() ||
          mesh->triangles.size() != data.mesh->triangles.size())
        throw Error(
            fmt::format("object '{}': a deforming shape must keep its vertex and triangle count",
                        scene_.objects[i].name));
      data.deformed = std::move(mesh);
      data.mesh = data.deformed.get();
      data.local_bounds = Aabb{};
      for (const auto& p : data.mesh->positions) data.local_bounds.extend(p);
      set_vertices(data, *data.deformed);
      rtcCommitScene(data.scene);  // refit
      place_object(i, data.to_world);
    }
    glm::mat4 m = i < state.object_to_world.size() ? state.object_to_world[i] : glm::mat4(1.0f);
    if (m != data.to_world) place_object(i, m);
  }
  bool lights_moved = false;
  for (size_t l = 0; l < state.lights.size(); ++l)
    lights_moved |= !same_light_geometry(state.lights[l], state_.lights[l]);
  state_ = state;
  if (lights_moved) place_lights();
  rtcCommitScene(top_);
}

namespace {

RTCRayHit make_ray(const glm::vec3& origin, const glm::vec3& dir, float tmax) {
  RTCRayHit rh;
  rh.ray.org_x = origin.x, rh.ray.org_y = origin.y, rh.ray.org_z = origin.z;
  rh.ray.dir_x = dir.x, rh.ray.dir_y = dir.y, rh.ray.dir_z = dir.z;
  rh.ray.tnear = 0.f;
  rh.ray.tfar = tmax;
  rh.ray.time = 0.f;
  rh.ray.mask = ~0u;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  return rh;
}

}  // namespace

bool EmbreeScene::intersect(const glm::vec3& origin, const glm::vec3& dir, float tmax,
                            Hit& hit) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh = make_ray(origin, dir, tmax);
  rtcIntersect1(top_, &context, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
  complete_hit(rh, origin, dir, hit);
  return true;
}

namespace {

// Streams go to Embree in chunks of 64: long enough for it to fill its 8-wide packets, short
// enough for the stack. `query(context, chunk, n)` traces a chunk of Embree rays (RTCRayHit or
// RTCRay) built from `rays`; `read(i, ray)` takes ray i's answer.
template <class EmbreeRay, class Query, class Read>
void stream_in_chunks(std::span<const Ray> rays, bool coherent, Query query, Read read) {
  constexpr size_t kStreamChunk = 64;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags =
      coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  alignas(64) EmbreeRay chunk[kStreamChunk];
  for (size_t start = 0; start < rays.size(); start += kStreamChunk) {
    size_t n = std::min(kStreamChunk, rays.size() - start);
    for (size_t i = 0; i < n; ++i) {
      const Ray& r = rays[start + i];
      RTCRayHit rh = make_ray(r.origin, r.dir, r.tmax);
      if constexpr (std::is_same_v<EmbreeRay, RTCRayHit>)
        chunk[i] = rh;
      else
        chunk[i] = rh.ray;
    }
    query(&context, chunk, unsigned(n));
    for (size_t i = 0; i < n; ++i) read(start + i, chunk[i]);
  }
}

}  // namespace

void EmbreeScene::intersect_stream(std::span<const Ray> rays, std::span<Hit> hits,
                                   std::span<uint8_t> found, bool coherent) const {
  stream_in_chunks<RTCRayHit>(
      rays, coherent,
      [&](RTCIntersectContext* context, RTCRayHit* chunk, unsigned n) {
        rtcIntersect1M(top_, context, chunk, n, sizeof(RTCRayHit));
      },
      [&](size_t i, const RTCRayHit& rh) {
        found[i] = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
        if (found[i]) complete_hit(rh, rays[i].origin, rays[i].dir, hits[i]);
      });
}

void EmbreeScene::occluded_stream(std::span<const Ray> rays, std::span<uint8_t> blocked,
                                  bool coherent) const {
  stream_in_chunks<RTCRay>(
      rays, coherent,
      [&](RTCIntersectContext* context, RTCRay* chunk, unsigned n) {
        rtcOccluded1M(top_, context, chunk, n, sizeof(RTCRay));
      },
      [&](size_t i, const RTCRay& ray) { blocked[i] = ray.tfar < 0.f; });  // -inf on a hit
}

void EmbreeScene::complete_hit(const RTCRayHit& rh, const glm::vec3& origin, const glm::vec3& dir,
                               Hit& hit) const {
  hit.t = rh.ray.tfar;
  hit.primitive = rh.hit.primID;
  hit.barycentric = {rh.hit.u, rh.hit.v};
  uint32_t object = rh.hit.instID[0] != RTC_INVALID_GEOMETRY_ID ? rh.hit.instID[0] : rh.hit.geomID;
  hit.object = object;
  if (object >= objects_.size()) {  // a luminaire
    hit.material = 0;
    hit.position = origin + hit.t * dir;
    const scene::Light& light = state_.lights[object - object_count()];
    hit.geometric_normal = hit.shading_normal = light.normal();
    return;
  }
  hit.material = scene_.objects[object].material;
  const ObjectData& data = objects_[object];
  const scene::Mesh& mesh = *data.geometry_mesh;
  const glm::uvec3 tri = mesh.triangles[rh.hit.primID];
  const float w = 1.f - rh.hit.u - rh.hit.v;
  const float u = rh.hit.u, v = rh.hit.v;
  const TriangleNormal& tn = data.triangle_normals[rh.hit.primID];
  const glm::vec3 p =
      w * mesh.positions[tri.x] + u * mesh.positions[tri.y] + v * mesh.positions[tri.z];
  if (data.flattened) {
    // World-space vertices and normals: no transform, and a flat triangle's normals are stored.
    hit.position = p;
    hit.geometric_normal = tn.face;
    if (tn.flat) {
      hit.shading_normal = tn.face;
      return;
    }
  } else {
    hit.position = glm::vec3(data.geometry_to_world * glm::vec4(p, 1.f));
    // Without vertex normals the winding orients the normal; with them, `face` is oriented already
    // (flat) or turned below to the interpolated normal's side.
    float side = mesh.normals.size() == mesh.positions.size() ? 1.f : data.winding;
    glm::vec3 ng = data.normal_to_world * tn.face;
    float len = glm::length(ng);
    hit.geometric_normal = len > 0 ? ng * (side / len) : glm::vec3(0, 1, 0);
    if (tn.flat) {
      hit.shading_normal = hit.geometric_normal;
      return;
    }
  }
  glm::vec3 n = w * mesh.normals[tri.x] + u * mesh.normals[tri.y] + v * mesh.normals[tri.z];
  if (!data.flattened) n = data.normal_to_world * n;
  float nl = glm::length(n);
  hit.shading_normal = nl > 0 ? n / nl : hit.geometric_normal;
  if (glm::dot(hit.geometric_normal, hit.shading_normal) < 0)
    hit.geometric_normal = -hit.geometric_normal;
}

bool EmbreeScene::occluded(const glm::vec3& origin, const glm::vec3& dir, float tmax) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray = make_ray(origin, dir, tmax).ray;
  rtcOccluded1(top_, &context, &ray);
  return ray.tfar < 0.f;  // Embree sets tfar to -inf on a hit
}

Triangle EmbreeScene::triangle(uint32_t object, uint32_t primitive) const {
  const ObjectData& data = objects_[object];
  const scene::Mesh& mesh = *data.geometry_mesh;
  const glm::uvec3 tri = mesh.triangles[primitive];
  Triangle out;
  for (int k = 0; k < 3; ++k) {
    out.p[k] = glm::vec3(data.geometry_to_world * glm::vec4(mesh.positions[tri[k]], 1.f));
    out.n[k] = mesh.normals.empty() ? glm::vec3(0.f) : data.normal_to_world * mesh.normals[tri[k]];
  }
  return out;
}

Aabb EmbreeScene::bounds() const {
  Aabb b;
  for (const auto& data : objects_)
    if (!data.bounds.empty()) b.extend(data.bounds.lo), b.extend(data.bounds.hi);
  return b;
}

}  // namespace pb::trace
