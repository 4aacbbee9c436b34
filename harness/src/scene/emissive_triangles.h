// The scene's emissive surfaces as a list of triangle lights, in world space for one frame: every
// triangle of an object whose material is emissive, with its flux Phi = pi A L (a Lambertian
// emitter of radiance L and area A sends pi L per unit area into its front hemisphere). Triangles
// of zero flux (no area, or no emission) are culled, as Paper III of seed 002 culls its dark
// textured emitters. Shared by the GPU direct-light pass and the light BVH, so both see the same
// lights as the photon tracer's mesh emitters (trace/lights.h).
#pragma once

#include <glm/glm.hpp>
#include <vector>

#include "scene/scene.h"

namespace pb::scene {

struct EmissiveTriangle {
  // Wound so that cross(p[1] - p[0], p[2] - p[0]) points along `normal`, the emitting side: the
  // side the mesh's vertex normals face (the tracer's rule for mesh emitters).
  glm::vec3 p[3];
  glm::vec3 normal{0.0f};    // unit
  glm::vec3 radiance{0.0f};  // W/(m^2 sr), from the front side
  float area = 0;            // m^2
  glm::vec3 flux{0.0f};      // pi A L, W
  uint32_t object = 0, triangle = 0;
  glm::vec3 centroid() const { return (p[0] + p[1] + p[2]) / 3.f; }
};

// The emissive triangles of `state`'s frame (objects at their transforms, deformed meshes at the
// frame's time).
std::vector<EmissiveTriangle> emissive_triangles(const Scene& scene, const FrameState& state);

// Whether object `i` emits (an emissive material with some positive emission).
bool is_emissive(const Scene& scene, size_t object);

}  // namespace pb::scene
