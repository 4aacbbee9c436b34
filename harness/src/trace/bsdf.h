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

#include <algorithm>
#include <cmath>
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

// Below this GGX roughness a rough material is treated as smooth (a delta lobe).
inline constexpr float kSmoothAlpha = 1e-3f;

// The diffuse lobe, which nearly every path vertex of the shipped scenes meets, is defined below
// and always inlined: the path tracers' loops are large enough that GCC's growth limits otherwise
// left these calls (and the random generator's) out of line. The other lobes live in bsdf.cpp.
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
  glm::vec3 eval_nondiffuse(const glm::vec3& wo, const glm::vec3& wi, Transport mode) const;
  float pdf_nondiffuse(const glm::vec3& wo, const glm::vec3& wi) const;
  bool sample_nondiffuse(const glm::vec3& wo, const glm::vec3& u, Transport mode,
                         BsdfSample& out) const;
  glm::vec3 eval_ggx(const glm::vec3& wo, const glm::vec3& wi, Transport mode, float* pdf) const;
  const scene::Material* material_;
  glm::vec3 ng_;  // geometric normal, the side shading normals point to
  Frame frame_;   // around the shading normal
  bool diffuse_ = false, delta_ = false;
  float alpha_ = 0;
};

[[gnu::always_inline]] inline Bsdf::Bsdf(const scene::Material& material, const Hit& hit)
    : material_(&material), ng_(hit.geometric_normal), frame_(hit.shading_normal) {
  using scene::MaterialType;
  switch (material.type) {
    case MaterialType::diffuse:
    case MaterialType::emissive:
      diffuse_ = true;
      break;
    case MaterialType::mirror:
    case MaterialType::dielectric:
      delta_ = true;
      break;
    case MaterialType::rough_conductor:
    case MaterialType::rough_dielectric:
      alpha_ = std::min(material.roughness, 1.f);
      delta_ = alpha_ < kSmoothAlpha;
      break;
  }
}

[[gnu::always_inline]] inline glm::vec3 Bsdf::eval(const glm::vec3& wo, const glm::vec3& wi,
                                                   Transport mode) const {
  if (!diffuse_) return eval_nondiffuse(wo, wi, mode);
  float so = glm::dot(wo, ng_), si = glm::dot(wi, ng_);
  if (so * si <= 0) return glm::vec3(0.f);  // two-sided, reflection only
  float cos_n = glm::dot(wi, frame_.n);
  if (cos_n * so < 0) return glm::vec3(0.f);
  return material_->albedo * (kInvPi * std::abs(cos_n));
}

[[gnu::always_inline]] inline float Bsdf::pdf(const glm::vec3& wo, const glm::vec3& wi) const {
  if (!diffuse_) return pdf_nondiffuse(wo, wi);
  float so = glm::dot(wo, ng_), si = glm::dot(wi, ng_);
  if (so * si <= 0) return 0;
  float c = glm::dot(wi, frame_.n) * (so > 0 ? 1.f : -1.f);
  return c > 0 ? c * kInvPi : 0;
}

[[gnu::always_inline]] inline bool Bsdf::sample(const glm::vec3& wo, const glm::vec3& u,
                                                Transport mode, BsdfSample& out) const {
  if (!diffuse_) return sample_nondiffuse(wo, u, mode, out);
  // Cosine-weighted about the shading normal, on wo's side.
  float so = glm::dot(wo, ng_);
  if (so == 0) return false;
  float side = so > 0 ? 1.f : -1.f;
  glm::vec3 local = cosine_hemisphere({u.x, u.y});
  local.z *= side;
  out = BsdfSample{};
  out.wi = frame_.to_world(local);
  if (glm::dot(out.wi, ng_) * side <= 0) return false;
  out.pdf = std::abs(local.z) * kInvPi;
  if (out.pdf <= 0) return false;
  out.weight = material_->albedo;
  out.normal = frame_.n * side;
  return true;
}

}  // namespace pb::trace
