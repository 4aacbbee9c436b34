// Every emitter of one frame, in one list: the scene's lights (point, spot, directional, quad,
// disc) followed by each object whose material is emissive. It answers the two questions of light
// transport: where do photons start (emission, photon tracer and SPPM) and how much light arrives
// at a point from a sampled emitter (next-event estimation in the reference renderer), with the
// same units as scene.h:
//   point, spot: radiant intensity I (W/sr), power 4 pi I (spot: the integral of I times the
//   falloff); directional: irradiance E (W/m^2) normal to the light, emitted through a square
//   perpendicular to
//     it that covers the scene's bounding sphere (side 2R), power E (2R)^2;
//   quad, disc and emissive surfaces: radiance L (W/m^2/sr) from the front side, power pi L area.
// Spot falloff: 1 inside spot_inner, 0 outside spot_outer, and smoothstep in cos(theta) between.
#pragma once

#include <glm/glm.hpp>
#include <vector>

#include "trace/embree_scene.h"

namespace pb::trace {

enum class EmitterType { point, spot, directional, quad, disc, mesh };

struct Emitter {
  EmitterType type = EmitterType::point;
  uint32_t source = 0;  // scene light index, or object index for a mesh
  glm::vec3 power{0.0f};
  float area = 0;                   // quad, disc, mesh (world, this frame)
  glm::vec3 radiance{0.0f};         // quad, disc, mesh
  std::vector<float> triangle_cdf;  // mesh: by world area, size triangles + 1
};

// A photon's start: the ray, and the power of the whole light (divide by paths x density).
struct EmissionRay {
  glm::vec3 origin{0.0f}, direction{0.0f};
  glm::vec3 power{0.0f};
  glm::vec3 normal{0.0f};  // surface emitters: the emitting side; else 0
  // Derivatives with respect to the two emission-domain coordinates (u, v) (photon differentials,
  // Schjoth et al. 2007): an area light moves the origin, a point light turns the direction.
  glm::vec3 dp_du{0.0f}, dp_dv{0.0f}, dd_du{0.0f}, dd_dv{0.0f};
};

// Light arriving at a shading point from one sampled emitter.
struct IncidentSample {
  glm::vec3 wi{0.0f};      // towards the light
  glm::vec3 point{0.0f};   // the sampled point on the emitter, or the point light's position
  glm::vec3 normal{0.0f};  // the emitter's normal there (surface emitters; else 0)
  float distance = 0;      // to the sampled point (infinity for a directional light)
  glm::vec3 weight{0.0f};  // incident radiance / pdf (the selection probability included)
  float pdf = 0;           // solid angle density including selection; 0 for delta lights
  bool delta = false;
  uint32_t emitter = 0;
};

float spot_falloff(float cos_theta, float cos_inner, float cos_outer);
// Next-event estimation towards point y (normal ny, the emitting side) drawn uniformly on a
// one-sided area emitter of `area` and `radiance` that was chosen with probability `select`, seen
// from p: the solid-angle density and radiance / density. False at the emitter's back.
bool area_incident_sample(const glm::vec3& p, const glm::vec3& y, const glm::vec3& ny, float area,
                          const glm::vec3& radiance, float select, IncidentSample& out);
// World bounds of a light's surface (quad, disc; a point for the others).
Aabb light_bounds(const scene::Light& light);

class LightSet {
 public:
  explicit LightSet(const EmbreeScene& world);
  uint32_t size() const { return uint32_t(emitters_.size()); }
  const Emitter& emitter(uint32_t i) const { return emitters_[i]; }
  float selection_probability(uint32_t i) const { return selection_pdf_[i]; }
  // Emitter index of a surface the camera can hit (quad or disc light geometry, emissive object),
  // or -1.
  int emitter_of_object(uint32_t object) const {
    return object < object_emitter_.size() ? object_emitter_[object] : -1;
  }

  // A photon from emitter `i` at emission-domain point `uv` (see EmissionDensity in photons.h),
  // with `u_dir` choosing the direction of surface emitters (cosine-distributed).
  EmissionRay emit(uint32_t i, glm::vec2 uv, glm::vec2 u_dir) const;

  // Next-event estimation: choose an emitter by power, then a point on it.
  bool sample_incident(const glm::vec3& p, float u_select, glm::vec2 u, IncidentSample& out) const;
  // The solid-angle density with which sample_incident would have produced the point `y` (an
  // emitter surface hit) seen from p: for multiple importance sampling with BSDF sampling.
  float pdf_incident(const glm::vec3& p, const Hit& y) const;
  // Radiance leaving emitter surface `y` towards wo (0 at the back and for non-emitters).
  // (Inline: every camera-path vertex asks.)
  [[gnu::always_inline]] glm::vec3 emitted(const Hit& y, const glm::vec3& wo) const {
    int i = emitter_of_object(y.object);
    if (i < 0 || glm::dot(wo, y.geometric_normal) <= 0) return glm::vec3(0.f);
    return emitters_[i].radiance;
  }

  // The emitter that selection number u in [0, 1) picks (by power, as sample_incident does).
  uint32_t choose(float u) const;
  // Surface emitters (quad, disc, mesh) have an area a path can hit; the others are points or
  // directions.
  bool has_area(uint32_t i) const {
    EmitterType t = emitters_[i].type;
    return t == EmitterType::quad || t == EmitterType::disc || t == EmitterType::mesh;
  }
  // The densities with which choose() + emit() (light paths) and choose() + sample_incident()
  // (next- event estimation) produce a light vertex, for the MIS weights of bidirectional path
  // tracing: position: selection probability / area for surface emitters, the selection probability
  // alone for points and directions (their delta is the same for every strategy and cancels);
  // direction: solid-angle density of the emitted direction `dir` leaving a surface emitter of
  // normal `n` (cosine), a point (uniform sphere) or a spot (uniform in the outer cone); for a
  // directional light, the density per unit area of the emission square (1 / (2R)^2), the light's
  // one direction being the same delta for every strategy.
  float position_pdf(uint32_t i) const;
  float direction_pdf(uint32_t i, const glm::vec3& n, const glm::vec3& dir) const;

  float scene_radius() const { return radius_; }
  glm::vec3 scene_center() const { return center_; }

 private:
  glm::vec3 mesh_point(const Emitter& e, glm::vec2 uv, glm::vec3* normal, glm::vec3* dp_du,
                       glm::vec3* dp_dv) const;
  const EmbreeScene& world_;
  std::vector<Emitter> emitters_;
  std::vector<float> selection_cdf_, selection_pdf_;
  std::vector<int> object_emitter_;  // per object (and light object), -1 if none
  glm::vec3 center_{0.0f};
  float radius_ = 1;
};

}  // namespace pb::trace
