// Next-event estimation through the light BVH (trace/light_bvh.h), with LightSet's incident-light
// interface: the reference path tracer's light choice in scenes of many lights. LightSet chooses an
// emitter by power alone, the same for every shading point, and an emissive mesh is one emitter
// whose triangles are chosen by area; here every emissive triangle, quad, disc, point and spot
// light is a light of its own (gather_nee_lights, trace/nee.h) and the light BVH's walk chooses
// among them by Paper III's importance seen from the shading point (distance, flux, the n.l bound
// and the orientation cone; Ray Tracing Gems ch. 18, Paper III of seed 002), then a uniform point
// on the chosen light.
//
// Directional lights have no position and stay outside the tree: a sample goes to them with their
// share of the total power (as power sampling would), else to the tree. The density of a point on
// an area light, for multiple importance sampling with a BSDF-sampled hit of it, is the walk's
// probability of that light from the previous vertex (LightBvh::pdf, the product of the walk's
// choices) times the tree's share times 1/area, converted to solid angle: exactly the density
// sample_incident draws it with.
#pragma once

#include <glm/glm.hpp>
#include <memory>
#include <vector>

#include "trace/embree_scene.h"
#include "trace/light_bvh.h"
#include "trace/lights.h"
#include "trace/nee.h"

namespace pb::trace {

class IncidentLightTree {
 public:
  // `lights` gives the directional lights and the powers of the tree's and their shares; the
  // tree's lights are the world's frame's (gather_nee_lights).
  IncidentLightTree(const EmbreeScene& world, const LightSet& lights,
                    const LightBvhOptions& options = {});

  // As LightSet::sample_incident, at shading point p of geometric normal n (zero: light from every
  // side counts); `emitter` is the LightSet emitter of the chosen light.
  bool sample_incident(const glm::vec3& p, const glm::vec3& n, float u_select, glm::vec2 u,
                       IncidentSample& out) const;
  // As LightSet::pdf_incident: the solid-angle density with which sample_incident(p, n, ...) would
  // have produced the emitter surface point `y`.
  float pdf_incident(const glm::vec3& p, const glm::vec3& n, const Hit& y) const;
  // The probability that sample_incident(p, n, ...) chooses the tree's light i.
  float pick_probability(const glm::vec3& p, const glm::vec3& n, uint32_t i) const;

  // The tree's lights (emissive triangles, quad, disc, point and spot lights) and the light a
  // surface hit belongs to (~0u: none).
  const NeeLightSet& lights() const { return set_; }
  uint32_t light_of(const Hit& y) const { return set_.find(y.object, y.primitive, world_); }
  const LightBvh* tree() const { return tree_.get(); }
  // The probability that a sample goes to the tree rather than to a directional light.
  float tree_share() const { return tree_share_; }

 private:
  const EmbreeScene& world_;
  const LightSet& light_set_;
  NeeLightSet set_;
  std::unique_ptr<LightBvh> tree_;
  std::vector<uint32_t> emitter_of_light_;  // per tree light: its LightSet emitter
  std::vector<uint32_t> directional_;       // LightSet emitters, chosen by power among themselves
  std::vector<float> directional_cdf_;      // size directional_ + 1
  float tree_share_ = 0;
};

}  // namespace pb::trace
