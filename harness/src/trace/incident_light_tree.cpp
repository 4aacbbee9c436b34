#include "trace/incident_light_tree.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "trace/photon_paths.h"
#include "trace/sampling.h"

namespace pb::trace {

IncidentLightTree::IncidentLightTree(const EmbreeScene& world, const LightSet& lights,
                                     const LightBvhOptions& options)
    : world_(world), light_set_(lights), set_(gather_nee_lights(world.scene(), world.state())) {
  const uint32_t objects = uint32_t(world.scene().objects.size());
  double tree_power = 0, directional_power = 0;
  for (uint32_t e = 0; e < lights.size(); ++e) {
    double power = std::max(0.f, detail::mean3(lights.emitter(e).power));
    if (lights.emitter(e).type == EmitterType::directional) {
      directional_.push_back(e);
      directional_power += power;
    } else {
      tree_power += power;
    }
  }
  directional_cdf_.assign(directional_.size() + 1, 0.f);
  double acc = 0;
  for (size_t k = 0; k < directional_.size(); ++k) {
    acc += std::max(0.f, detail::mean3(lights.emitter(directional_[k]).power));
    directional_cdf_[k + 1] = directional_power > 0 ? float(acc / directional_power) : 0.f;
  }
  if (!set_.lights.empty()) {
    tree_ = std::make_unique<LightBvh>(set_.primitives, options);
    tree_share_ = tree_power + directional_power > 0
                      ? float(tree_power / (tree_power + directional_power))
                      : (directional_.empty() ? 1.f : 0.f);
  }
  emitter_of_light_.resize(set_.lights.size());
  for (size_t i = 0; i < set_.lights.size(); ++i) {
    uint32_t g = set_.group[i];
    emitter_of_light_[i] = g < objects ? uint32_t(std::max(0, lights.emitter_of_object(g)))
                                       : g - objects;  // scene lights lead LightSet's list
  }
}

float IncidentLightTree::pick_probability(const glm::vec3& p, const glm::vec3& n,
                                          uint32_t i) const {
  if (!tree_ || i >= set_.lights.size()) return 0;
  return tree_share_ * tree_->pdf(p, n, i);
}

bool IncidentLightTree::sample_incident(const glm::vec3& p, const glm::vec3& n, float u_select,
                                        glm::vec2 u, IncidentSample& out) const {
  if (!(u_select < tree_share_)) {  // a directional light, chosen by power among them
    if (directional_.empty() || tree_share_ >= 1.f) return false;
    float v = std::clamp((u_select - tree_share_) / (1.f - tree_share_), 0.f, 1.f);
    size_t k = std::clamp<size_t>(
        size_t(std::upper_bound(directional_cdf_.begin(), directional_cdf_.end(), v) -
               directional_cdf_.begin()) -
            1,
        0, directional_.size() - 1);
    float select = (1.f - tree_share_) * (directional_cdf_[k + 1] - directional_cdf_[k]);
    if (!(select > 0)) return false;
    const scene::Light& light = world_.state().lights[light_set_.emitter(directional_[k]).source];
    out.emitter = directional_[k];
    out.delta = true;
    out.pdf = 0;
    out.wi = -glm::normalize(light.direction);
    out.distance = std::numeric_limits<float>::infinity();
    out.weight = light.radiant / select;
    return true;
  }
  LightPick pick;
  if (!tree_->walk(p, n, double(u_select) / tree_share_, pick, nullptr) || !(pick.pdf > 0))
    return false;
  const float select = tree_share_ * pick.pdf;
  const NeeLight& l = set_.lights[pick.light];
  out.emitter = emitter_of_light_[pick.light];
  if (l.area_light())
    return area_incident_sample(p, area_point(l, u), l.normal, l.area, l.radiance, select, out);
  glm::vec3 d = l.origin - p;
  float dist2 = glm::dot(d, d);
  if (!(dist2 > 0)) return false;
  out.delta = true;
  out.pdf = 0;
  out.point = l.origin;
  out.distance = std::sqrt(dist2);
  out.wi = d / out.distance;
  out.normal = glm::vec3(0.f);
  float falloff = 1.f;
  if (l.shape == NeeLight::Shape::spot) {
    float ci = l.cos_inner, co = l.cos_outer;
    if (ci < co) std::swap(ci, co);
    falloff = spot_falloff(-glm::dot(out.wi, l.normal), ci, co);
    if (falloff <= 0) return false;
  }
  out.weight = l.radiance * (falloff / (dist2 * select));
  return true;
}

float IncidentLightTree::pdf_incident(const glm::vec3& p, const glm::vec3& n, const Hit& y) const {
  uint32_t i = light_of(y);
  if (i == ~0u) return 0;
  const NeeLight& l = set_.lights[i];
  glm::vec3 d = y.position - p;
  float dist2 = glm::dot(d, d);
  float cos_l = std::abs(glm::dot(y.geometric_normal, d)) / std::sqrt(dist2);
  if (!(cos_l > 0) || !(l.area > 0)) return 0;
  return pick_probability(p, n, i) * dist2 / (cos_l * l.area);
}

}  // namespace pb::trace
