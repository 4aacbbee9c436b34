// Photon differentials as seed 003 (Fabianowski and Dingliana 2009, §4) starts and carries them,
// as the photon tracer's vertex policy: the tracer transfers differentials along segments and
// through specular hits (Igehy 1999); these rules say how they start at a point light (§4.1,
// Eqs. 8-9), restart at a diffuse bounce (§4.3, Eqs. 10-13) and grow under Russian roulette
// (§4.2). The photons stored are the tracer's own choice (TraceSettings::store); each record's
// flags hold the bits of the float spacing Delta its footprint was scaled by, so that
// |footprint_u| / Delta is the positional differential's length. Header-only so that the tests
// check the very code the plugin runs.
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <glm/glm.hpp>
#include <numbers>

#include "photonbench/photons.h"
#include "photonbench/trace_math.h"

namespace pd {

// Eq. 8: the directional differentials of direction d = (cos phi sin theta, sin phi sin theta,
// cos theta) with respect to cos theta and phi, pre-scaled by sin theta and 1 / sin theta: unit
// vectors orthogonal to d and to each other (in the frame d is given in).
inline void isotropic_differentials(const glm::vec3& d, glm::vec3& d_cos_theta, glm::vec3& d_phi) {
  const float sin_theta = std::sqrt(std::max(0.f, d.x * d.x + d.y * d.y));
  float cos_phi = 1, sin_phi = 0;
  if (sin_theta > 1e-6f) cos_phi = d.x / sin_theta, sin_phi = d.y / sin_theta;
  d_cos_theta = {-cos_phi * d.z, -sin_phi * d.z, sin_theta};
  d_phi = {-sin_phi, cos_phi, 0.f};
}

class DifferentialRules final : public pb::trace::VertexPolicy {
 public:
  pb::trace::VertexDecision decide(const pb::trace::Interaction& at) const override {
    pb::trace::VertexDecision d =
        pb::trace::default_decision(at, at.settings->store, at.settings->max_bounces);
    d.photon_flags = std::bit_cast<uint32_t>(at.footprint->spacing);
    return d;
  }
  bool shapes_footprints() const override { return true; }

  // §4.1: a point (or spot) light's photons share one spacing Delta, the square root of the solid
  // angle per photon (Eq. 9: 2 sqrt(pi / n) over the sphere), along Eq. 8's unit differentials;
  // the footprint is unchanged in area, and round where the (u, v) one was not. A surface emitter
  // (quad, disc, emissive triangles), a case the paper leaves open (§8: "footprint calculation for
  // area light sources"), emits from a point of its surface in a cosine-distributed direction:
  // that is §4.3's diffuse re-emission at the light, with the footprint the light's area per
  // photon and Delta = 2 sqrt(pi) times the (u, v) spacing (Eq. 9's 2 sqrt(pi / n) for n photons
  // spread evenly over the light), so that its footprints grow with distance as a point light's.
  // A directional light keeps its (u, v) differentials: its parallel beam does not spread.
  void emitted(pb::trace::EmitterKind kind, const glm::vec3& direction,
               pb::trace::Footprint& f) const override {
    if (kind == pb::trace::EmitterKind::quad || kind == pb::trace::EmitterKind::disc ||
        kind == pb::trace::EmitterKind::mesh) {
      glm::vec3 normal = glm::cross(f.dp_du, f.dp_dv);
      if (!(glm::length(normal) > 0)) return;
      normal = glm::normalize(glm::dot(normal, direction) < 0 ? -normal : normal);
      // The same footprint (Delta dp) with the new Delta, then re-emitted about the light's normal.
      const float delta = 2 * std::sqrt(std::numbers::pi_v<float>) * f.spacing;
      f.dp_du *= f.spacing / delta, f.dp_dv *= f.spacing / delta;
      f.spacing = delta;
      scattered_diffusely(normal, direction, f);
      return;
    }
    if (f.dp_du != glm::vec3(0.f) || f.dp_dv != glm::vec3(0.f)) return;
    const float solid_angle = glm::length(glm::cross(f.dd_du, f.dd_dv)) * f.spacing * f.spacing;
    f.spacing = std::sqrt(solid_angle);
    isotropic_differentials(direction, f.dd_du, f.dd_dv);
  }

  // §4.3: absorption and re-emission. New directional differentials by Eq. 8 in the surface's
  // frame, the same Delta, and a virtual origin v behind the hit (Eq. 11) chosen so that the
  // footprint keeps its area (Eqs. 10-13; Eq. 8's vectors are unit and orthogonal, so Eq. 13 is
  // v = sqrt |dp_du x dp_dv| with the arriving differentials).
  void scattered_diffusely(const glm::vec3& normal, const glm::vec3& direction,
                           pb::trace::Footprint& f) const override {
    const pb::trace::Frame frame(normal);
    glm::vec3 d1, d2;
    isotropic_differentials(frame.to_local(direction), d1, d2);
    const float v_origin = std::sqrt(glm::length(glm::cross(f.dp_du, f.dp_dv)));
    f.dd_du = frame.to_world(d1);
    f.dd_dv = frame.to_world(d2);
    f.dp_du = v_origin * f.dd_du;
    f.dp_dv = v_origin * f.dd_dv;
  }

  // §4.2: a photon surviving with probability p has its footprint grown by 1 / sqrt(p).
  void survived_roulette(float survival, pb::trace::Footprint& f) const override {
    const float grow = 1.f / std::sqrt(survival);
    f.dp_du *= grow, f.dp_dv *= grow, f.dd_du *= grow, f.dd_dv *= grow;
  }
};

// The tracer's settings for §4's photons, from the toolkit's (paths, bounces, the classes stored;
// Russian roulette from the second hit, the first scaling the flux by the albedo): these rules as
// the vertex policy, and the first hits stored too (the lit surface area T_auto divides by; the
// technique drops them before the upload unless store_first_hit asks for them). With
// `first_hit_roulette`, the roulette is played "whenever a photon encounters a surface" (§4.2), the
// first hit included, so a photon leaving its first hit with probability p has its footprint
// grown by 1 / p there too.
inline pb::trace::TraceSettings differential_trace_settings(pb::trace::TraceSettings settings,
                                                            const DifferentialRules& rules,
                                                            bool first_hit_roulette) {
  settings.policy = &rules;
  settings.footprints = true;  // implied by the rules' hooks; the density estimate is the footprint
  settings.store |= pb::trace::kDirectPhotons;
  if (first_hit_roulette) settings.rr_start = 0;
  return settings;
}

}  // namespace pd
