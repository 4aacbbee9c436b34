// Scattering of the six scene materials (scene.h), shared by the photon tracer and the reference
// renderer so that both solve the same equation.
//
// Conventions: `wo` points away from the surface towards where the path came from (camera side for
// radiance, light side for photons), `wi` towards where it goes next; both unit, world space.
// eval() returns f(wo, wi) |cos(theta_i)| against the shading normal. Smooth dielectrics scale
// refracted radiance by (eta_i / eta_t)^2 in radiance mode and not for photons (Veach 1997 §5.2:
// importance and radiance differ by that factor across an interface).
//
// Rough conductors and dielectrics use GGX with the Smith height-correlated masking-shadowing term
// and sample the distribution of visible normals (Heitz 2018, "Sampling the GGX Distribution of
// Visible Normals", JCGT 7(4)); the rough dielectric follows Walter et al. 2007, "Microfacet Models
// for Refraction through Rough Surfaces" (eqs. 17-21).
#pragma once

#include <glm/glm.hpp>

#include "scene/scene.h"
#include "trace/embree_scene.h"
#include "trace/sampling.h"

namespace pb::trace {

enum class Transport { radiance, importance };

struct BsdfSample {
  glm::vec3 wi{0.0f};
  glm::vec3 weight{0.0f};  // f |cos_i| / pdf
  float pdf = 0;           // solid angle density; for a delta lobe, the probability of the lobe
  bool delta = false;      // mirror or smooth dielectric: not reachable by light sampling
  bool transmitted = false;
  glm::vec3 normal{0.0f};  // the (micro)normal it reflected or refracted about, facing wo
  float eta = 1;           // eta_i / eta_t of a refraction (1 for reflection)
};

// Exact unpolarised Fresnel reflectance of a dielectric interface; `eta` = eta_t / eta_i for the
// side cos_i > 0 points to (a negative cos_i means the other side).
float fresnel_dielectric(float cos_i, float eta);

class Bsdf {
 public:
  Bsdf(const scene::Material& material, const Hit& hit);
  // Heckbert's D: diffuse and emissive materials. Everything else (mirror, dielectrics, rough GGX)
  // counts as S in path classes.
  bool is_diffuse() const { return diffuse_; }
  // Has a lobe that eval() can answer (diffuse or rough): light sampling (NEE) makes sense.
  bool can_eval() const { return !delta_; }
  glm::vec3 eval(const glm::vec3& wo, const glm::vec3& wi, Transport mode) const;
  float pdf(const glm::vec3& wo, const glm::vec3& wi) const;
  // `u`: two dimensions for the direction, one for the lobe (reflect / refract).
  bool sample(const glm::vec3& wo, const glm::vec3& u, Transport mode, BsdfSample& out) const;
  // Diffuse albedo (for photon deposits and SPPM): f = albedo / pi on wo's side.
  const glm::vec3& albedo() const { return material_->albedo; }

 private:
  glm::vec3 eval_ggx(const glm::vec3& wo, const glm::vec3& wi, Transport mode, float* pdf) const;
  const scene::Material* material_;
  glm::vec3 ng_;  // geometric normal, the side shading normals point to
  Frame frame_;   // around the shading normal
  bool diffuse_ = false, delta_ = false;
  float alpha_ = 0;
};

}  // namespace pb::trace
