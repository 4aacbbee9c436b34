#include "trace/bsdf.h"

#include <algorithm>
#include <cmath>

namespace pb::trace {
namespace {

// ---- GGX (isotropic alpha), in a local frame with the macro normal along +z
// ----------------------

float ggx_d(const glm::vec3& m, float alpha) {
  if (m.z <= 0) return 0;
  float a2 = alpha * alpha;
  float t = m.z * m.z * (a2 - 1.f) + 1.f;
  return a2 / (kPi * t * t);
}

// Smith Lambda for GGX: G1 = 1 / (1 + Lambda).
float ggx_lambda(const glm::vec3& w, float alpha) {
  float z2 = w.z * w.z;
  if (z2 <= 0) return 1e30f;
  float tan2 = std::max(0.f, 1.f - z2) / z2;
  return 0.5f * (-1.f + std::sqrt(1.f + alpha * alpha * tan2));
}
float ggx_g1(const glm::vec3& w, float alpha) { return 1.f / (1.f + ggx_lambda(w, alpha)); }
float ggx_g2(const glm::vec3& wo, const glm::vec3& wi, float alpha) {  // height-correlated
  return 1.f / (1.f + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha));
}

// Heitz 2018, Listing 1: stretch the view direction to the hemisphere configuration, sample the
// projected disk with the half that the hemisphere hides warped away, unstretch. wo.z > 0.
glm::vec3 sample_ggx_vndf(const glm::vec3& wo, float alpha, glm::vec2 u) {
  glm::vec3 vh = glm::normalize(glm::vec3(alpha * wo.x, alpha * wo.y, wo.z));
  float lensq = vh.x * vh.x + vh.y * vh.y;
  glm::vec3 t1 = lensq > 0 ? glm::vec3(-vh.y, vh.x, 0) / std::sqrt(lensq) : glm::vec3(1, 0, 0);
  glm::vec3 t2 = glm::cross(vh, t1);
  float r = std::sqrt(u.x), phi = 2.f * kPi * u.y;
  float p1 = r * std::cos(phi), p2 = r * std::sin(phi);
  float s = 0.5f * (1.f + vh.z);
  p2 = (1.f - s) * std::sqrt(std::max(0.f, 1.f - p1 * p1)) + s * p2;
  glm::vec3 nh = p1 * t1 + p2 * t2 + std::sqrt(std::max(0.f, 1.f - p1 * p1 - p2 * p2)) * vh;
  return glm::normalize(glm::vec3(alpha * nh.x, alpha * nh.y, std::max(1e-6f, nh.z)));
}

glm::vec3 schlick(const glm::vec3& f0, float cos_theta) {
  float m = std::clamp(1.f - cos_theta, 0.f, 1.f);
  float m5 = (m * m) * (m * m) * m;
  return f0 + (1.f - f0) * m5;
}

glm::vec3 reflect_about(const glm::vec3& wo, const glm::vec3& n) {
  return 2.f * glm::dot(wo, n) * n - wo;
}

// Refraction of wo about n (facing wo) with eta = eta_i / eta_t; false on total internal
// reflection.
bool refract_about(const glm::vec3& wo, const glm::vec3& n, float eta, glm::vec3& wi) {
  float cos_i = glm::dot(wo, n);
  float sin2_t = eta * eta * std::max(0.f, 1.f - cos_i * cos_i);
  if (sin2_t >= 1.f) return false;
  float cos_t = std::sqrt(1.f - sin2_t);
  wi = -eta * wo + (eta * cos_i - cos_t) * n;
  return true;
}

}  // namespace

float fresnel_dielectric(float cos_i, float eta) {
  cos_i = std::clamp(cos_i, -1.f, 1.f);
  if (cos_i < 0) {
    eta = 1.f / eta;
    cos_i = -cos_i;
  }
  float sin2_t = (1.f - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1.f) return 1.f;
  float cos_t = std::sqrt(1.f - sin2_t);
  float r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  float r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  return 0.5f * (r_parl * r_parl + r_perp * r_perp);
}

glm::vec3 Bsdf::eval_nondiffuse(const glm::vec3& wo, const glm::vec3& wi, Transport mode) const {
  if (delta_) return glm::vec3(0.f);
  float unused;
  return eval_ggx(wo, wi, mode, &unused);
}

float Bsdf::pdf_nondiffuse(const glm::vec3& wo, const glm::vec3& wi) const {
  if (delta_) return 0;
  float p = 0;
  eval_ggx(wo, wi, Transport::importance, &p);
  return p;
}

glm::vec3 Bsdf::eval_ggx(const glm::vec3& wo_world, const glm::vec3& wi_world, Transport mode,
                         float* pdf) const {
  *pdf = 0;
  float so = glm::dot(wo_world, ng_), si = glm::dot(wi_world, ng_);
  if (so == 0) return glm::vec3(0.f);
  float side = so > 0 ? 1.f : -1.f;  // work with wo in the upper hemisphere
  glm::vec3 wo = frame_.to_local(wo_world), wi = frame_.to_local(wi_world);
  wo.z *= side, wi.z *= side;
  if (wo.z <= 0) return glm::vec3(0.f);
  bool reflect = so * si > 0;
  if (reflect != (wi.z > 0)) return glm::vec3(0.f);  // shading and geometric normals disagree
  if (material_->type == scene::MaterialType::rough_conductor) {
    if (!reflect) return glm::vec3(0.f);
    glm::vec3 m = glm::normalize(wo + wi);
    float d = ggx_d(m, alpha_);
    glm::vec3 f =
        schlick(material_->specular, glm::dot(wo, m)) * (d * ggx_g2(wo, wi, alpha_) / (4.f * wo.z));
    *pdf = ggx_g1(wo, alpha_) * d / (4.f * wo.z);
    return f;  // f * cos_i: the cos_i of f's denominator cancels
  }
  // Rough dielectric (Walter et al. 2007). etap = eta_t / eta_i seen from wo's side.
  float etap = side > 0 ? material_->ior : 1.f / material_->ior;
  glm::vec3 m = reflect ? wo + wi : wi * etap + wo;  // generalised half vector, eq. 16
  if (glm::dot(m, m) == 0) return glm::vec3(0.f);
  m = glm::normalize(m);
  if (m.z < 0) m = -m;
  float dot_o = glm::dot(wo, m), dot_i = glm::dot(wi, m);
  if (dot_i * wi.z < 0 || dot_o * wo.z < 0) return glm::vec3(0.f);  // back-facing microfacet
  float fresnel = fresnel_dielectric(dot_o, etap);
  float d = ggx_d(m, alpha_);
  float g2 = ggx_g2(wo, wi, alpha_);
  float vndf = ggx_g1(wo, alpha_) * d * dot_o / wo.z;  // D_wo(m), Heitz 2018 eq. 3
  if (reflect) {
    *pdf = fresnel * vndf / (4.f * dot_o);
    return glm::vec3(fresnel * d * g2 / (4.f * wo.z));
  }
  float denom = dot_i + dot_o / etap;
  denom *= denom;
  float dwm_dwi = std::abs(dot_i) / denom;  // Jacobian of the refraction half vector, eq. 17
  *pdf = (1.f - fresnel) * vndf * dwm_dwi;
  float ft = (1.f - fresnel) * d * g2 * std::abs(dot_i * dot_o) / (wo.z * denom);
  if (mode == Transport::radiance) ft /= etap * etap;
  return glm::vec3(ft);
}

bool Bsdf::sample_nondiffuse(const glm::vec3& wo_world, const glm::vec3& u, Transport mode,
                             BsdfSample& out) const {
  float so = glm::dot(wo_world, ng_);
  if (so == 0) return false;
  float side = so > 0 ? 1.f : -1.f;
  glm::vec3 n_side = frame_.n * side;
  auto to_world = [&](glm::vec3 v) {
    v.z *= side;
    return frame_.to_world(v);
  };
  using scene::MaterialType;
  out = BsdfSample{};
  glm::vec3 wo = frame_.to_local(wo_world);
  wo.z *= side;
  if (wo.z <= 0) return false;  // seen from below its shading normal: absorb
  MaterialType type = material_->type;
  if (type == MaterialType::mirror || (delta_ && type == MaterialType::rough_conductor)) {
    out.wi = reflect_about(wo_world, n_side);
    if (glm::dot(out.wi, ng_) * side <= 0) return false;
    out.weight =
        type == MaterialType::mirror ? material_->specular : schlick(material_->specular, wo.z);
    out.pdf = 1;
    out.delta = true;
    out.normal = n_side;
    return true;
  }
  float etap = side > 0 ? material_->ior : 1.f / material_->ior;  // eta_t / eta_i
  if (delta_) {  // smooth dielectric: choose reflection with probability F
    float fresnel = fresnel_dielectric(wo.z, etap);
    out.delta = true;
    out.normal = n_side;
    if (u.z < fresnel) {
      out.wi = reflect_about(wo_world, n_side);
      if (glm::dot(out.wi, ng_) * side <= 0) return false;
      out.weight = glm::vec3(1.f);
      out.pdf = fresnel;
      return true;
    }
    float eta = 1.f / etap;
    if (!refract_about(wo_world, n_side, eta, out.wi)) return false;
    if (glm::dot(out.wi, ng_) * side >= 0) return false;
    out.weight = glm::vec3(mode == Transport::radiance ? eta * eta : 1.f);
    out.pdf = 1.f - fresnel;
    out.transmitted = true;
    out.eta = eta;
    return true;
  }
  // Rough: sample a visible microfacet normal, then reflect or refract about it.
  glm::vec3 m = sample_ggx_vndf(wo, alpha_, {u.x, u.y});
  glm::vec3 wi;
  bool transmit = false;
  if (type == MaterialType::rough_conductor) {
    wi = reflect_about(wo, m);
  } else {
    float fresnel = fresnel_dielectric(glm::dot(wo, m), etap);
    if (u.z < fresnel) {
      wi = reflect_about(wo, m);
    } else {
      if (!refract_about(wo, m, 1.f / etap, wi)) return false;
      transmit = true;
    }
  }
  if (transmit ? wi.z >= 0 : wi.z <= 0) return false;
  out.wi = to_world(wi);
  if ((glm::dot(out.wi, ng_) * side > 0) == transmit) return false;
  glm::vec3 f = eval_ggx(wo_world, out.wi, mode, &out.pdf);
  if (out.pdf <= 0) return false;
  out.weight = f / out.pdf;
  out.transmitted = transmit;
  out.eta = transmit ? 1.f / etap : 1.f;
  out.normal = to_world(m);
  return true;
}

}  // namespace pb::trace
