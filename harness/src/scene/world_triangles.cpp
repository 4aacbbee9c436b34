#include "scene/world_triangles.h"

#include <fmt/format.h>

#include "photonbench/error.h"

namespace pb::scene {

std::vector<uint32_t> first_triangles(const Scene& scene) {
  std::vector<uint32_t> first(scene.objects.size() + 1, 0);
  for (size_t o = 0; o < scene.objects.size(); ++o)
    first[o + 1] = first[o] + uint32_t(scene.objects[o].mesh.triangles.size());
  return first;
}

WorldTriangles::WorldTriangles(const Scene& scene)
    : scene_(scene),
      meshes_(scene.objects.size()),
      owned_(scene.objects.size()),
      placed_(scene.objects.size()),
      first_vertex_(scene.objects.size() + 1, 0),
      first_triangle_(first_triangles(scene)) {
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    meshes_[o] = &scene.objects[o].mesh;
    first_vertex_[o + 1] = first_vertex_[o] + uint32_t(scene.objects[o].mesh.positions.size());
  }
  vertices_.resize(first_vertex_.back());
  triangles_.resize(first_triangle_.back());
}

void WorldTriangles::write_object(uint32_t object, const glm::mat4& to_world) {
  const Mesh& mesh = *meshes_[object];
  const glm::mat3 normal_to_world = glm::transpose(glm::inverse(glm::mat3(to_world)));
  const bool has_normals = mesh.normals.size() == mesh.positions.size();
  const uint32_t v0 = first_vertex_[object];
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    layout::GpuSceneVertex& out = vertices_[v0 + v];
    out.position = glm::vec4(glm::vec3(to_world * glm::vec4(mesh.positions[v], 1.f)), 1.f);
    out.normal = has_normals ? glm::vec4(glm::normalize(normal_to_world * mesh.normals[v]), 1.f)
                             : glm::vec4(0.f);
  }
  const uint32_t t0 = first_triangle_[object];
  const uint32_t material = scene_.objects[object].material;
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const glm::uvec3 tri = mesh.triangles[t] + glm::uvec3(v0);
    glm::vec3 p0 = vertices_[tri.x].position, p1 = vertices_[tri.y].position,
              p2 = vertices_[tri.z].position;
    glm::vec3 cross = glm::cross(p1 - p0, p2 - p0);
    float length = glm::length(cross);
    layout::GpuSceneTriangle& out = triangles_[t0 + t];
    out.vertices_object = glm::uvec4(tri, object);
    out.normal_area = glm::vec4(length > 0 ? cross / length : glm::vec3(0.f), 0.5f * length);
    out.material_local = glm::uvec4(material, uint32_t(t), 0u, 0u);
  }
  placed_[object] = to_world;
}

const std::vector<uint32_t>& WorldTriangles::update(const FrameState& state,
                                                    std::span<const Mesh> deformed) {
  changed_.clear();
  std::vector<bool> rewrite(meshes_.size(), !written_);
  for (size_t k = 0; k < state.deformed_objects.size() && k < deformed.size(); ++k) {
    uint32_t o = state.deformed_objects[k];
    const Mesh& mesh = deformed[k];
    if (mesh.positions.size() != first_vertex_[o + 1] - first_vertex_[o] ||
        mesh.triangles.size() != first_triangle_[o + 1] - first_triangle_[o])
      throw Error(fmt::format(
          "object '{}' deformed from {} to {} triangles: the scene's triangle numbering needs a "
          "deforming shape to keep its tessellation",
          scene_.objects[o].name, first_triangle_[o + 1] - first_triangle_[o],
          mesh.triangles.size()));
    owned_[o] = std::make_unique<Mesh>(mesh);
    meshes_[o] = owned_[o].get();
    rewrite[o] = true;
  }
  for (uint32_t o = 0; o < meshes_.size(); ++o) {
    if (!rewrite[o] && placed_[o] == state.object_to_world[o]) continue;
    write_object(o, state.object_to_world[o]);
    changed_.push_back(o);
  }
  written_ = true;
  if (!changed_.empty()) {
    total_area_ = 0;
    for (const auto& t : triangles_) total_area_ += t.normal_area.w;
  }
  return changed_;
}

}  // namespace pb::scene
