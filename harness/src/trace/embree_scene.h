// The CPU half of the World: an Embree 3 scene built from a pb::scene::Scene, one instance per
// object, so a frame where objects move costs a transform per moving object and a rebuild of the
// small top-level BVH; a deformable shape (Shape::animated, the pool's water) refits its own BVH
// from new vertices.
//
// Quad and disc lights are part of the scene too (unless turned off): a one-sided emitter that is
// seen by camera rays, hit by BSDF-sampled rays (so the reference renderer can weight them by MIS)
// and that absorbs what hits it, as the physical luminaire it models.
//
// Queries (intersect, occluded, triangle) are const and safe from any number of threads; update()
// must not run concurrently with them.
#pragma once

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>
#include <limits>
#include <memory>
#include <span>
#include <vector>

#include "scene/scene.h"

namespace pb::trace {

inline constexpr uint32_t kNoObject = ~0u;
// The tmax of a ray that may hit anything in front of it.
inline constexpr float kUnboundedRay = std::numeric_limits<float>::infinity();

struct Hit {
  float t = 0;
  glm::vec3 position{0.0f};
  glm::vec3 geometric_normal{0.0f};  // unit, world; the side the shading normals point to
  glm::vec3 shading_normal{0.0f};    // unit, world, interpolated vertex normal
  glm::vec2 barycentric{0.0f};       // Embree's (u, v): weights of vertices 1 and 2
  uint32_t object = kNoObject;       // Scene::objects index, or light_object(l) for area light l
  uint32_t primitive = 0;
  uint32_t material = 0;  // Scene::materials index (objects only)
};

// A ray for the stream queries: origin + t dir, t in (0, tmax].
struct Ray {
  glm::vec3 origin{0.0f}, dir{0.0f, 0.0f, 1.0f};
  float tmax = kUnboundedRay;
};

// World-space data of one triangle (for ray differentials: the normal's derivative along the
// surface).
struct Triangle {
  glm::vec3 p[3];
  glm::vec3 n[3];
};

struct Aabb {
  glm::vec3 lo{std::numeric_limits<float>::max()}, hi{-std::numeric_limits<float>::max()};
  void extend(const glm::vec3& p) { lo = glm::min(lo, p), hi = glm::max(hi, p); }
  bool empty() const { return lo.x > hi.x; }
  // Does the segment origin + t dir, t in [0, tmax], touch the box? (slab test)
  bool intersects(const glm::vec3& origin, const glm::vec3& dir, float tmax) const;
};

struct EmbreeOptions {
  bool area_lights_as_geometry = true;
  // Objects that never move (Object::moves() false) go into the top-level scene in world space
  // rather than behind an instance: one BVH level less on every ray. If such an object's transform
  // changes anyway, its vertices are re-transformed (correct, just slower than an instance).
  bool flatten_static = true;
  // Rigid objects that move go there as well: for a world built for one frame (a reference
  // render's), whose update() seldom comes or never. Deforming shapes stay instances (they refit).
  bool flatten_moving = false;
};

// The options of a world built for one frame: every rigid object in the top-level scene.
inline EmbreeOptions one_frame_options() {
  EmbreeOptions options;
  options.flatten_moving = true;
  return options;
}

class EmbreeScene {
 public:
  EmbreeScene(const scene::Scene& scene, const scene::FrameState& state,
              EmbreeOptions options = {});
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  // Moves the objects and lights to `state` and refits deformed meshes.
  void update(const scene::FrameState& state);

  // Closest hit along origin + t dir, t in (0, tmax]; dir need not be unit (t is in its units).
  bool intersect(const glm::vec3& origin, const glm::vec3& dir, float tmax, Hit& hit) const;
  // Any hit along origin + t dir, t in (0, tmax).
  bool occluded(const glm::vec3& origin, const glm::vec3& dir, float tmax) const;
  // The same queries for many rays at once, as streams (rtcIntersect1M, rtcOccluded1M): no call
  // per ray, and with `coherent` (rays from neighbouring points in neighbouring directions, such
  // as a camera's through one image row, or their shadow rays to one light) Embree packs them into
  // SIMD packets that walk the BVH together. found[i]: ray i hit, hits[i] as intersect;
  // blocked[i]: ray i is occluded.
  void intersect_stream(std::span<const Ray> rays, std::span<Hit> hits, std::span<uint8_t> found,
                        bool coherent) const;
  void occluded_stream(std::span<const Ray> rays, std::span<uint8_t> blocked, bool coherent) const;

  const scene::Scene& scene() const { return scene_; }
  const scene::FrameState& state() const { return state_; }
  uint32_t object_count() const { return uint32_t(scene_.objects.size()); }
  uint32_t light_object(uint32_t light) const { return object_count() + light; }
  bool is_light_object(uint32_t object) const {
    return object >= object_count() && object != kNoObject;
  }
  const glm::mat4& object_to_world(uint32_t object) const { return objects_[object].to_world; }
  // The object's mesh at the current frame (object space; deformed meshes are the current shape).
  const scene::Mesh& mesh(uint32_t object) const { return *objects_[object].mesh; }
  Triangle triangle(uint32_t object, uint32_t primitive) const;
  // The scene-wide index of an object's triangle (photonbench/scene_layout.h's numbering).
  uint32_t scene_triangle(uint32_t object, uint32_t primitive) const {
    return first_triangle_[object] + primitive;
  }
  Aabb object_bounds(uint32_t object) const {
    return objects_[object].bounds;
  }                     // world, this frame
  Aabb bounds() const;  // world bounds of all objects this frame
  // Offset for spawning rays from a surface point, scaled to the coordinates (float precision).
  static float ray_epsilon(const glm::vec3& p) {
    return 1e-4f * std::max(1.f, std::max(std::abs(p.x), std::max(std::abs(p.y), std::abs(p.z))));
  }
  static RTCDevice device();

 private:
  struct TriangleNormal {
    glm::vec3 face{0.0f, 1.0f, 0.0f};  // unit, of the vertices the BVH holds
    bool flat = true;  // no vertex normals, or all three along `face` (oriented as they are)
  };
  struct ObjectData {
    bool flattened = false;    // world-space triangles in the top-level scene
    RTCScene scene = nullptr;  // instanced: the object's own scene
    RTCGeometry geometry =
        nullptr;  // triangles (in `scene`, or in the top-level scene if flattened)
    RTCGeometry instance = nullptr;     // instanced: in the top-level scene
    glm::mat4 to_world{1.0f};           // the frame's object-to-world transform
    glm::mat4 geometry_to_world{1.0f};  // of the vertices the BVH holds (identity when flattened)
    glm::mat3 normal_to_world{1.0f};    // inverse transpose of geometry_to_world
    const scene::Mesh* mesh = nullptr;  // object space
    const scene::Mesh* geometry_mesh = nullptr;    // what the BVH holds: *mesh, or world_mesh
    std::unique_ptr<scene::Mesh> deformed;         // owned current mesh of an animated shape
    scene::Mesh world_mesh;                        // flattened: the mesh in world space
    std::vector<TriangleNormal> triangle_normals;  // of geometry_mesh
    float winding = 1;  // -1 where geometry_to_world mirrors (the cross product's sign flips)
    Aabb local_bounds;  // object space
    Aabb bounds;        // world
  };
  void set_vertices(ObjectData& data, const scene::Mesh& mesh);
  // The hit record of Embree's answer for the ray origin + t dir.
  void complete_hit(const RTCRayHit& answer, const glm::vec3& origin, const glm::vec3& dir,
                    Hit& hit) const;
  void place_object(uint32_t i, const glm::mat4& to_world);
  void place_lights();

  const scene::Scene& scene_;
  scene::FrameState state_;
  EmbreeOptions options_;
  RTCScene top_ = nullptr;
  std::vector<ObjectData> objects_;
  std::vector<RTCGeometry> light_geometry_;  // one per scene light (null unless quad or disc)
  std::vector<uint32_t> first_triangle_;     // per object: scene::first_triangles
};

}  // namespace pb::trace
