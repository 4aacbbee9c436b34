#include "trace/lights.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "trace/sampling.h"

namespace pb::trace {
namespace {

float mean(const glm::vec3& v) { return (v.x + v.y + v.z) / 3.f; }

// Direction of an equal-area sphere / cone point and its derivatives in (u, v).
void sphere_direction(glm::vec2 uv, float cos_max, glm::vec3& d, glm::vec3& dd_du,
                      glm::vec3& dd_dv) {
  float span = 1.f - cos_max;  // 2 for the full sphere
  float z = 1.f - uv.x * span;
  float r = std::sqrt(std::max(0.f, 1.f - z * z));
  float phi = 2.f * kPi * uv.y;
  float c = std::cos(phi), s = std::sin(phi);
  d = {r * c, r * s, z};
  float dr = z * span / std::max(r, 1e-4f);  // dr/du = -z/r dz/du, dz/du = -span
  dd_du = {dr * c, dr * s, -span};
  dd_dv = 2.f * kPi * glm::vec3(-r * s, r * c, 0.f);
}

}  // namespace

float spot_falloff(float cos_theta, float cos_inner, float cos_outer) {
  if (cos_theta >= cos_inner) return 1.f;
  if (cos_theta <= cos_outer) return 0.f;
  float t = (cos_theta - cos_outer) / (cos_inner - cos_outer);
  return t * t * (3.f - 2.f * t);
}

LightSet::LightSet(const EmbreeScene& world) : world_(world) {
  const scene::Scene& scene = world.scene();
  const scene::FrameState& state = world.state();
  Aabb bounds = world.bounds();
  if (!bounds.empty()) {
    center_ = 0.5f * (bounds.lo + bounds.hi);
    radius_ = std::max(1e-3f, 0.5f * glm::length(bounds.hi - bounds.lo));
  }
  object_emitter_.assign(world.object_count() + state.lights.size(), -1);
  for (uint32_t l = 0; l < state.lights.size(); ++l) {
    const scene::Light& light = state.lights[l];
    Emitter e;
    e.source = l;
    switch (light.type) {
      case scene::LightType::point:
        e.type = EmitterType::point;
        e.power = 4.f * kPi * light.radiant;
        break;
      case scene::LightType::spot: {
        e.type = EmitterType::spot;
        float ci = std::cos(light.spot_inner), co = std::cos(light.spot_outer);
        if (ci < co) std::swap(ci, co);
        // Integral of the falloff over the sphere: full cone to the inner angle, and the smoothstep
        // in cos(theta) integrates to half its width.
        e.power = 2.f * kPi * light.radiant * ((1.f - ci) + 0.5f * (ci - co));
        break;
      }
      case scene::LightType::directional:
        e.type = EmitterType::directional;
        e.power = light.radiant * (4.f * radius_ * radius_);
        break;
      case scene::LightType::quad:
      case scene::LightType::disc:
        e.type = light.type == scene::LightType::quad ? EmitterType::quad : EmitterType::disc;
        e.area = light.area();
        e.radiance = light.radiant;
        e.power = kPi * light.radiant * e.area;
        if (world.is_light_object(world.light_object(l)))
          object_emitter_[world.light_object(l)] = int(emitters_.size());
        break;
    }
    emitters_.push_back(std::move(e));
  }
  for (uint32_t o = 0; o < world.object_count(); ++o) {
    const scene::Material& m = scene.materials[scene.objects[o].material];
    if (m.type != scene::MaterialType::emissive ||
        std::max({m.emission.x, m.emission.y, m.emission.z}) <= 0)
      continue;
    Emitter e;
    e.type = EmitterType::mesh;
    e.source = o;
    e.radiance = m.emission;
    const scene::Mesh& mesh = world.mesh(o);
    e.triangle_cdf.resize(mesh.triangles.size() + 1, 0.f);
    double acc = 0;
    for (uint32_t t = 0; t < mesh.triangles.size(); ++t) {
      Triangle tri = world.triangle(o, t);
      acc += 0.5 * glm::length(glm::cross(tri.p[1] - tri.p[0], tri.p[2] - tri.p[0]));
      e.triangle_cdf[t + 1] = float(acc);
    }
    if (acc <= 0) continue;
    for (float& c : e.triangle_cdf) c = float(c / acc);
    e.triangle_cdf.back() = 1.f;
    e.area = float(acc);
    e.power = kPi * e.radiance * e.area;
    object_emitter_[o] = int(emitters_.size());
    emitters_.push_back(std::move(e));
  }
  selection_cdf_.assign(emitters_.size() + 1, 0.f);
  selection_pdf_.assign(emitters_.size(), 0.f);
  double total = 0;
  for (const auto& e : emitters_) total += std::max(0.f, mean(e.power));
  double acc = 0;
  for (size_t i = 0; i < emitters_.size(); ++i) {
    double p = total > 0 ? std::max(0.f, mean(emitters_[i].power)) / total : 0.0;
    selection_pdf_[i] = float(p);
    acc += p;
    selection_cdf_[i + 1] = float(acc);
  }
  if (!emitters_.empty()) selection_cdf_.back() = 1.f;
}

glm::vec3 LightSet::mesh_point(const Emitter& e, glm::vec2 uv, glm::vec3* normal, glm::vec3* dp_du,
                               glm::vec3* dp_dv) const {
  const auto& cdf = e.triangle_cdf;
  size_t n = cdf.size() - 1;
  size_t t = std::clamp<size_t>(
      size_t(std::upper_bound(cdf.begin(), cdf.end(), uv.x) - cdf.begin()) - 1, 0, n - 1);
  while (t < n - 1 && cdf[t + 1] <= cdf[t]) ++t;
  float width = cdf[t + 1] - cdf[t];
  float u = width > 0 ? std::clamp((uv.x - cdf[t]) / width, 0.f, 1.f) : 0.5f;
  Triangle tri = world_.triangle(e.source, uint32_t(t));
  glm::vec3 e1 = tri.p[1] - tri.p[0], e2 = tri.p[2] - tri.p[0];
  float su = std::max(std::sqrt(u), 1e-3f);
  glm::vec2 b = triangle_from_unit({u, uv.y});
  glm::vec3 ng = glm::normalize(glm::cross(e1, e2));
  if (glm::dot(ng, tri.n[0] + tri.n[1] + tri.n[2]) < 0) ng = -ng;
  *normal = ng;
  if (dp_du) {
    // b1 = 1 - sqrt(u'), b2 = v sqrt(u'), u' = (u - cdf_t) / width.
    *dp_du = (-0.5f / su * e1 + 0.5f * uv.y / su * e2) / std::max(width, 1e-12f);
    *dp_dv = su * e2;
  }
  return tri.p[0] + b.x * e1 + b.y * e2;
}

EmissionRay LightSet::emit(uint32_t i, glm::vec2 uv, glm::vec2 u_dir) const {
  const Emitter& e = emitters_[i];
  EmissionRay r;
  r.power = e.power;
  if (e.type == EmitterType::mesh) {
    r.origin = mesh_point(e, uv, &r.normal, &r.dp_du, &r.dp_dv);
    r.direction = Frame(r.normal).to_world(cosine_hemisphere(u_dir));
    return r;
  }
  const scene::Light& light = world_.state().lights[e.source];
  switch (e.type) {
    case EmitterType::point: {
      r.origin = light.position;
      sphere_direction(uv, -1.f, r.direction, r.dd_du, r.dd_dv);
      break;
    }
    case EmitterType::spot: {
      float ci = std::cos(light.spot_inner), co = std::cos(light.spot_outer);
      if (ci < co) std::swap(ci, co);
      glm::vec3 d, du, dv;
      sphere_direction(uv, co, d, du, dv);
      Frame f(glm::normalize(light.direction));
      r.origin = light.position;
      r.direction = f.to_world(d);
      r.dd_du = f.to_world(du);
      r.dd_dv = f.to_world(dv);
      // Power through the whole outer cone, times the falloff in this direction.
      r.power = light.radiant * (2.f * kPi * (1.f - co) * spot_falloff(d.z, ci, co));
      break;
    }
    case EmitterType::directional: {
      Frame f(glm::normalize(light.direction));
      r.direction = f.n;
      r.origin = center_ - f.n * (radius_ * 1.01f) + (2.f * uv.x - 1.f) * radius_ * f.t +
                 (2.f * uv.y - 1.f) * radius_ * f.b;
      r.dp_du = 2.f * radius_ * f.t;
      r.dp_dv = 2.f * radius_ * f.b;
      break;
    }
    case EmitterType::quad:
    case EmitterType::disc: {
      r.normal = light.normal();
      r.origin = light.surface_point(uv, &r.dp_du, &r.dp_dv);
      r.direction = Frame(r.normal).to_world(cosine_hemisphere(u_dir));
      break;
    }
    case EmitterType::mesh:
      break;
  }
  return r;
}

bool LightSet::sample_incident(const glm::vec3& p, float u_select, glm::vec2 u,
                               IncidentSample& out) const {
  if (emitters_.empty()) return false;
  uint32_t i = choose(u_select);
  float select = selection_pdf_[i];
  if (select <= 0) return false;
  const Emitter& e = emitters_[i];
  out.emitter = uint32_t(i);
  if (has_area(i)) {
    glm::vec3 y, ny;
    if (e.type != EmitterType::mesh) {
      const scene::Light& light = world_.state().lights[e.source];
      y = light.surface_point(u);
      ny = light.normal();
    } else {
      y = mesh_point(e, u, &ny, nullptr, nullptr);
    }
    return area_incident_sample(p, y, ny, e.area, e.radiance, select, out);
  }
  const scene::Light& light = world_.state().lights[e.source];
  out.delta = true;
  out.pdf = 0;
  if (e.type == EmitterType::directional) {
    out.wi = -glm::normalize(light.direction);
    out.distance = std::numeric_limits<float>::infinity();
    out.weight = light.radiant / select;
    return true;
  }
  glm::vec3 d = light.position - p;
  float dist2 = glm::dot(d, d);
  if (dist2 <= 0) return false;
  out.point = light.position;
  out.distance = std::sqrt(dist2);
  out.wi = d / out.distance;
  float falloff = 1.f;
  if (e.type == EmitterType::spot) {
    float ci = std::cos(light.spot_inner), co = std::cos(light.spot_outer);
    if (ci < co) std::swap(ci, co);
    falloff = spot_falloff(-glm::dot(out.wi, glm::normalize(light.direction)), ci, co);
    if (falloff <= 0) return false;
  }
  out.weight = light.radiant * (falloff / (dist2 * select));
  return true;
}

float LightSet::pdf_incident(const glm::vec3& p, const Hit& y) const {
  int i = emitter_of_object(y.object);
  if (i < 0) return 0;
  const Emitter& e = emitters_[i];
  glm::vec3 d = y.position - p;
  float dist2 = glm::dot(d, d);
  float cos_l = std::abs(glm::dot(y.geometric_normal, d)) / std::sqrt(dist2);
  if (cos_l <= 0 || e.area <= 0) return 0;
  return selection_pdf_[i] * dist2 / (cos_l * e.area);
}

bool area_incident_sample(const glm::vec3& p, const glm::vec3& y, const glm::vec3& ny, float area,
                          const glm::vec3& radiance, float select, IncidentSample& out) {
  glm::vec3 d = y - p;
  float dist2 = glm::dot(d, d);
  if (dist2 <= 0 || !(area > 0)) return false;
  float dist = std::sqrt(dist2);
  out.wi = d / dist;
  out.point = y;
  out.normal = ny;
  float cos_l = -glm::dot(out.wi, ny);
  if (cos_l <= 0) return false;  // the back of a one-sided emitter
  out.distance = dist;
  out.pdf = select * dist2 / (cos_l * area);
  out.weight = radiance / out.pdf;
  out.delta = false;
  return true;
}

Aabb light_bounds(const scene::Light& light) {
  Aabb box;
  if (light.type == scene::LightType::disc) {
    // The square around the disc holds it.
    for (float su : {-1.f, 1.f})
      for (float sv : {-1.f, 1.f})
        box.extend(light.position + su * light.edge_u + sv * light.edge_v);
  } else if (light.type == scene::LightType::quad) {
    for (glm::vec2 uv : {glm::vec2(0, 0), glm::vec2(1, 0), glm::vec2(0, 1), glm::vec2(1, 1)})
      box.extend(light.surface_point(uv));
  } else {
    box.extend(light.position);
  }
  return box;
}

uint32_t LightSet::choose(float u) const {
  size_t n = emitters_.size();
  if (n == 1) return 0;  // the common scene of one light: no search (every camera vertex asks)
  size_t i =
      std::clamp<size_t>(size_t(std::upper_bound(selection_cdf_.begin(), selection_cdf_.end(), u) -
                                selection_cdf_.begin()) -
                             1,
                         0, n - 1);
  while (i < n - 1 && selection_pdf_[i] <= 0) ++i;
  return uint32_t(i);
}

float LightSet::position_pdf(uint32_t i) const {
  const Emitter& e = emitters_[i];
  if (has_area(i)) return e.area > 0 ? selection_pdf_[i] / e.area : 0.f;
  return selection_pdf_[i];
}

float LightSet::direction_pdf(uint32_t i, const glm::vec3& n, const glm::vec3& dir) const {
  const Emitter& e = emitters_[i];
  if (has_area(i)) return std::max(0.f, glm::dot(n, dir)) * kInvPi;
  const scene::Light& light = world_.state().lights[e.source];
  switch (e.type) {
    case EmitterType::point:
      return 1.f / (4.f * kPi);
    case EmitterType::spot: {
      float ci = std::cos(light.spot_inner), co = std::cos(light.spot_outer);
      if (ci < co) std::swap(ci, co);
      float c = glm::dot(dir, glm::normalize(light.direction));
      return c >= co ? 1.f / (2.f * kPi * (1.f - co)) : 0.f;
    }
    case EmitterType::directional:
      return 1.f / (4.f * radius_ * radius_);
    default:
      return 0.f;
  }
}

}  // namespace pb::trace
