#include "scene/emissive_triangles.h"

#include <algorithm>
#include <numbers>

namespace pb::scene {

bool is_emissive(const Scene& scene, size_t object) {
  const Material& m = scene.materials[scene.objects[object].material];
  return m.type == MaterialType::emissive &&
         std::max({m.emission.x, m.emission.y, m.emission.z}) > 0;
}

std::vector<EmissiveTriangle> emissive_triangles(const Scene& scene, const FrameState& state) {
  std::vector<EmissiveTriangle> out;
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    if (!is_emissive(scene, o)) continue;
    const glm::vec3 radiance = scene.materials[scene.objects[o].material].emission;
    const bool deformed = std::find(state.deformed_objects.begin(), state.deformed_objects.end(),
                                    uint32_t(o)) != state.deformed_objects.end();
    const Mesh mesh = deformed ? scene.mesh_at(o, state.time) : scene.objects[o].mesh;
    const glm::mat4& to_world = state.object_to_world[o];
    const glm::mat3 normal_to_world = glm::transpose(glm::inverse(glm::mat3(to_world)));
    for (uint32_t t = 0; t < mesh.triangles.size(); ++t) {
      EmissiveTriangle e;
      glm::vec3 shading_sum{0.0f};
      for (int k = 0; k < 3; ++k) {
        uint32_t v = mesh.triangles[t][k];
        e.p[k] = glm::vec3(to_world * glm::vec4(mesh.positions[v], 1.f));
        if (v < mesh.normals.size()) shading_sum += normal_to_world * mesh.normals[v];
      }
      glm::vec3 cross = glm::cross(e.p[1] - e.p[0], e.p[2] - e.p[0]);
      float twice_area = glm::length(cross);
      if (!(twice_area > 0)) continue;  // degenerate: no area, no flux
      e.normal = cross / twice_area;
      if (glm::dot(e.normal, shading_sum) < 0) {
        std::swap(e.p[1], e.p[2]);
        e.normal = -e.normal;
      }
      e.radiance = radiance;
      e.area = 0.5f * twice_area;
      e.flux = std::numbers::pi_v<float> * e.area * radiance;
      e.object = uint32_t(o);
      e.triangle = t;
      out.push_back(e);
    }
  }
  return out;
}

}  // namespace pb::scene
