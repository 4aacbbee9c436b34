// The scene's triangles as a technique sees them (pb::SharedPasses::scene_triangles) and the
// targets of the raster pass that draws them (pb::SharedPasses::draw_scene). The GPU records'
// layouts and the scene-wide triangle numbering are in photonbench/scene_layout.h; a photon
// record's `triangle` uses the same numbering.
#pragma once

#include <cstdint>
#include <span>

#include "photonbench/gpu.h"
#include "photonbench/scene_layout.h"

namespace pb {

inline constexpr uint32_t kNoTriangle = PB_NO_TRIANGLE;

// The scene's objects' triangles in world space at the current frame, on the GPU (storage buffers
// for a technique's own shaders) and on the host (the same records, for CPU work). Built on the
// first call of scene_triangles(); then rewritten in the frame's "scene-update" pass, and only in a
// frame where an object moved or deformed. A view: valid until the next frame's scene-update.
struct SceneTriangles {
  const gpu::Buffer* vertices = nullptr;   // layout::GpuSceneVertex[vertex_count()]
  const gpu::Buffer* triangles = nullptr;  // layout::GpuSceneTriangle[triangle_count()]
  std::span<const layout::GpuSceneVertex> host_vertices;
  std::span<const layout::GpuSceneTriangle> host_triangles;
  // Per object and one past the last: object o's triangles are [first_triangle[o],
  // first_triangle[o + 1]).
  std::span<const uint32_t> first_triangle;
  double total_area = 0;       // m^2, the sum of the triangles' areas
  uint32_t changed_frame = 0;  // the frame whose scene-update last rewrote the records
  uint32_t vertex_count() const { return uint32_t(host_vertices.size()); }
  uint32_t triangle_count() const { return uint32_t(host_triangles.size()); }
  float area(uint32_t triangle) const { return host_triangles[triangle].normal_area.w; }
  uint32_t object(uint32_t triangle) const { return host_triangles[triangle].vertices_object.w; }
  uint32_t material(uint32_t triangle) const { return host_triangles[triangle].material_local.x; }
};

// What draw_scene draws into: the technique's own images, all of one size, in the general layout,
// made with the colour (depth) attachment usage. Only `area` is cleared and drawn (zero extent: the
// whole image), so one image can hold many small views side by side (an atlas of hemi-planes).
struct SceneTarget {
  const gpu::Image* position = nullptr;  // RGBA32F: world xyz, w = 1 (cleared to 0: no surface)
  const gpu::Image* normal = nullptr;    // RGBA32F: shading normal facing the viewer, w = material
  const gpu::Image* triangle = nullptr;  // R32_UINT: scene-wide triangle id, or kNoTriangle
  const gpu::Image* depth = nullptr;     // D32_SFLOAT
  vk::Rect2D area{};
};

}  // namespace pb
