// Scenes built in code for the Embree-side tests (trace_test, reference_test): meshes, materials,
// objects and lights filled in directly, never through a scene file.
#pragma once

#include <algorithm>
#include <cmath>
#include <glm/glm.hpp>
#include <memory>
#include <string>
#include <vector>

#include "scene/scene.h"
#include "trace/sampling.h"  // kPi

namespace pb::trace::test_scenes {

class FixedShape final : public scene::Shape {
 public:
  explicit FixedShape(scene::Mesh mesh) : mesh_(std::move(mesh)) {}
  scene::Mesh tessellate(float) const override { return mesh_; }
  std::string kind() const override { return "fixed"; }

 private:
  scene::Mesh mesh_;
};

// A parallelogram corner + s eu + t ev, facing cross(eu, ev).
inline scene::Mesh quad_mesh(glm::vec3 corner, glm::vec3 eu, glm::vec3 ev) {
  scene::Mesh m;
  glm::vec3 n = glm::normalize(glm::cross(eu, ev));
  m.positions = {corner, corner + eu, corner + eu + ev, corner + ev};
  m.normals = {n, n, n, n};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

inline void append(scene::Mesh& to, const scene::Mesh& from) {
  uint32_t base = uint32_t(to.positions.size());
  to.positions.insert(to.positions.end(), from.positions.begin(), from.positions.end());
  to.normals.insert(to.normals.end(), from.normals.begin(), from.normals.end());
  for (auto t : from.triangles) to.triangles.push_back(t + glm::uvec3(base));
}

// Axis-aligned box; faces point outward, or inward for an enclosure (each face's (a, b) order below
// winds it inward).
inline scene::Mesh box_mesh(glm::vec3 lo, glm::vec3 hi, bool inward) {
  scene::Mesh m;
  glm::vec3 d = hi - lo;
  glm::vec3 ex{d.x, 0, 0}, ey{0, d.y, 0}, ez{0, 0, d.z};
  auto face = [&](glm::vec3 c, glm::vec3 a, glm::vec3 b) {
    append(m, inward ? quad_mesh(c, a, b) : quad_mesh(c, b, a));
  };
  face(lo, ez, ex);       // -y
  face(lo + ey, ex, ez);  // +y
  face(lo, ey, ez);       // -x
  face(lo + ex, ez, ey);  // +x
  face(lo, ex, ey);       // -z
  face(lo + ez, ey, ex);  // +z
  return m;
}

inline scene::Mesh sphere_mesh(glm::vec3 c, float r, int seg) {
  scene::Mesh m;
  int stacks = seg / 2;
  for (int i = 0; i <= stacks; ++i)
    for (int j = 0; j <= seg; ++j) {
      float th = kPi * i / stacks, ph = 2 * kPi * j / seg;
      glm::vec3 n{std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph)};
      m.positions.push_back(c + r * n);
      m.normals.push_back(n);
    }
  for (int i = 0; i < stacks; ++i)
    for (int j = 0; j < seg; ++j) {
      uint32_t a = i * (seg + 1) + j, b = a + seg + 1;
      if (i > 0) m.triangles.push_back({a, a + 1, b});
      if (i < stacks - 1) m.triangles.push_back({a + 1, b + 1, b});
    }
  return m;
}

// Irradiance at p (normal n) from a Lambertian polygon of radiance L in front of p, by Lambert's
// contour integral E = L/2 |sum_i theta_i (n . g_i)| (theta_i the angle p sees edge i under, g_i
// the unit normal of the plane through p and the edge). Zero when p is behind the polygon.
inline double polygon_irradiance(const std::vector<glm::dvec3>& poly, glm::dvec3 p, glm::dvec3 n,
                                 double radiance) {
  glm::dvec3 facing = glm::cross(poly[1] - poly[0], poly[2] - poly[0]);
  if (glm::dot(p - poly[0], facing) <= 0) return 0;
  double sum = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    glm::dvec3 ra = glm::normalize(poly[i] - p),
               rb = glm::normalize(poly[(i + 1) % poly.size()] - p);
    glm::dvec3 g = glm::cross(ra, rb);
    double len = glm::length(g);
    if (len > 0) sum += std::acos(std::clamp(glm::dot(ra, rb), -1.0, 1.0)) * glm::dot(n, g / len);
  }
  return 0.5 * radiance * std::abs(sum);
}

struct TestScene {
  scene::Scene scene;
  scene::FrameState state;
  uint32_t material(scene::MaterialType type, glm::vec3 albedo = glm::vec3(0.5f),
                    glm::vec3 emission = glm::vec3(0.f)) {
    scene::Material m;
    m.name = "m" + std::to_string(scene.materials.size());
    m.type = type;
    m.albedo = albedo;
    m.emission = emission;
    scene.materials.push_back(m);
    return uint32_t(scene.materials.size() - 1);
  }
  uint32_t object(scene::Mesh mesh, uint32_t material, glm::mat4 to_world = glm::mat4(1.f)) {
    scene::Object o;
    o.name = "o" + std::to_string(scene.objects.size());
    o.shape = std::make_shared<FixedShape>(mesh);
    o.mesh = std::move(mesh);
    o.material = material;
    scene.objects.push_back(std::move(o));
    state.object_to_world.push_back(to_world);
    return uint32_t(scene.objects.size() - 1);
  }
  void light(scene::Light l) { state.lights.push_back(l); }
  void camera(glm::vec3 position, glm::vec3 target, glm::vec3 up, float fov_deg) {
    state.camera.position = position;
    state.camera.target = target;
    state.camera.up = up;
    state.camera.fov_y = glm::radians(fov_deg);
  }
  void point_light(glm::vec3 p, float intensity) {
    scene::Light l;
    l.type = scene::LightType::point;
    l.position = p;
    l.radiant = glm::vec3(intensity);
    state.lights.push_back(l);
  }
};

}  // namespace pb::trace::test_scenes
