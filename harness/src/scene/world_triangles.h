// The scene's triangles in world space at one frame, as the GPU records of
// photonbench/scene_layout.h, in its scene-wide numbering (object o's mesh triangle t is triangle
// first_triangle()[o] + t). Kept in step with the animation object by object: a frame rewrites only
// the objects that moved or deformed since the last.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "photonbench/scene_layout.h"
#include "scene/scene.h"

namespace pb::scene {

// Per object and one past the last: the first scene-wide triangle index of each object.
std::vector<uint32_t> first_triangles(const Scene& scene);

class WorldTriangles {
 public:
  // The numbering and the storage; no record is written before the first update().
  explicit WorldTriangles(const Scene& scene);

  // Moves to `state`. `deformed[k]` is the object-space mesh of object state.deformed_objects[k] at
  // this time (a deformed mesh must keep its vertex and triangle counts: the numbering is fixed).
  // Rewrites every object the first time, then the objects whose transform changed or that
  // deformed; returns them (empty: nothing changed).
  const std::vector<uint32_t>& update(const FrameState& state, std::span<const Mesh> deformed);

  std::span<const layout::GpuSceneVertex> vertices() const { return vertices_; }
  std::span<const layout::GpuSceneTriangle> triangles() const { return triangles_; }
  std::span<const uint32_t> first_triangle() const { return first_triangle_; }
  // Object o's vertices are [first_vertex()[o], first_vertex()[o + 1]).
  std::span<const uint32_t> first_vertex() const { return first_vertex_; }
  double total_area() const { return total_area_; }

 private:
  void write_object(uint32_t object, const glm::mat4& to_world);

  const Scene& scene_;
  std::vector<const Mesh*> meshes_;           // each object's current object-space mesh
  std::vector<std::unique_ptr<Mesh>> owned_;  // the last deformed mesh of an animated shape
  std::vector<glm::mat4> placed_;             // the transform each object's records were written at
  bool written_ = false;
  std::vector<uint32_t> first_vertex_, first_triangle_, changed_;
  std::vector<layout::GpuSceneVertex> vertices_;
  std::vector<layout::GpuSceneTriangle> triangles_;
  double total_area_ = 0;
};

}  // namespace pb::scene
