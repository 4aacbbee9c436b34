// The reference's estimators and their switches, below the renderer (reference.h) so that its
// passes (path_tracing_pass.h, bdpt.h, photon_mapping_pass.h, estimator_pilot.h) and the
// path-space rule (path_space.h) can name them.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "config/reference_rules.h"

namespace pb::trace {

// `max_bounces` 0 means untruncated: Russian roulette ends paths, this many scattering vertices
// at most keeps them finite (the photon tracer stops at 31 on its side).
inline constexpr uint32_t kUntruncatedBounces = 64;

// How the unbiased estimator reaches emitters: both strategies weighted by MIS (the default), or
// one alone at full weight (for tests that compare strategies on the same pixel; each alone is
// unbiased too, only noisier, except that BSDF sampling alone cannot reach delta lights).
enum class LightStrategies : uint8_t { mis, nee_only, bsdf_only };

// How path tracing's next-event estimation chooses a light: by power alone, the same choice for
// every shading point (trace::LightSet: an emissive mesh is one emitter, its triangles chosen by
// area; the default), or by the light BVH's walk from the shading point over every emissive
// triangle and scene light (trace/incident_light_tree.h; Paper III of seed 002), whose MIS density
// for a BSDF-sampled emitter hit is that walk's probability from the previous vertex. Power is the
// default because it won at equal time where the tree should win most: on lamp-hall (1,152
// emissive triangles) the tree's walk took the variance per sample to 0.42x but the time per
// sample to 3.6x (README.md, "Many lights"). Bidirectional path tracing always chooses by power:
// its MIS weights use light-vertex densities that do not depend on the shading point.
enum class LightSelection : uint8_t { power, bvh };
// Their names are config::light_sampler_names(), in this order: what the config's reference block
// (`light_sampler`) and `photonbench reference --light-sampler` accept.
inline std::string_view light_selection_name(LightSelection s) {
  return config::light_sampler_names().at(size_t(s));
}
inline std::optional<LightSelection> parse_light_selection(std::string_view name) {
  for (LightSelection s : {LightSelection::power, LightSelection::bvh})
    if (light_selection_name(s) == name) return s;
  return std::nullopt;
}

// How bidirectional path tracing weights its strategies: the power heuristic (Veach 1997 §9.2.3,
// the default), or the same weight for every strategy that can sample the path (unbiased too, only
// noisier; for tests, where every strategy's share should be large enough to be checked).
enum class MisHeuristic : uint8_t { power, uniform };

// The unbiased estimator for the part of path space photon mapping does not own: path tracing with
// next-event estimation (the anchor), bidirectional path tracing with MIS (bdpt.h), or automatic:
// a pilot picks one of them per render (of an image of 18000 pixels or more; smaller ones are
// bidirectional, since the pilot would cost too much of them). The render starts as path tracing;
// on a grid of about 2000 of the pixels the pilot reads its iterations (photon mapping's share
// included, the same for both) and runs one of bidirectional path tracing beside each. From the
// per-iteration variances measured there and the rays each would trace per iteration of the whole
// image, it predicts the cost of reaching the error target with either: bidirectional path tracing
// (from kPilotMinIterations on, when cheaper by kPilotMargin than what path tracing has left)
// restarts the render; path tracing keeps it when the pilot would spend more than kPilotBudget of
// its predicted render (rays) or of the time limit (seconds), or after kPilotIterations. A small
// bright region that path tracing finds by chance makes its sample variance grow with the samples
// for a long while (8 iterations of the earlier fixed pilot picked path tracing on cornell-box,
// whose hotspot makes it 8x slower there), so only path tracing may be picked on a short pilot.
// Rays rather than seconds where the render is not ended by its time limit, so that a seed
// gives one image; a ray of bidirectional path tracing counts kBdptRayCost of path tracing's.
// Their names are config::estimator_names(), in this order: what the config's reference block and
// `photonbench reference --estimator` accept.
enum class Estimator : uint8_t { pt, bdpt, automatic };
inline std::string_view estimator_name(Estimator e) {  // "pt", "bdpt", "auto"
  return config::estimator_names().at(size_t(e));
}
inline std::optional<Estimator> parse_estimator(std::string_view name) {
  for (Estimator e : {Estimator::pt, Estimator::bdpt, Estimator::automatic})
    if (estimator_name(e) == name) return e;
  return std::nullopt;
}
inline constexpr uint32_t kPilotIterations = 32;  // render iterations watched, at most
// Bidirectional path tracing is chosen from this many pilot iterations on.
inline constexpr uint32_t kPilotMinIterations = 8;
// ... and runs at most this many bidirectional iterations (its estimate settles early; path
// tracing's, read from the render for free, is the one that grows on rare paths).
inline constexpr uint32_t kPilotBdptIterations = 16;
// The pilot's own rays stay within this share of path tracing's predicted render, and its own time
// within this share of the render's time limit.
inline constexpr double kPilotBudget = 0.03;
// Bidirectional path tracing is chosen when predicted cheaper by more than this factor.
inline constexpr double kPilotMargin = 1.1;
// Bidirectional path tracing's time per ray over path tracing's, measured (`photonbench reference
// --estimator pt|bdpt`, 320x180, 16 iterations, 3 alternating rounds: on cornell-box its Mrays/s
// are 0.53 of path tracing's, on pillars 0.64-0.76; 0.74 and 0.76 before path tracing ran as a
// wavefront of ray streams, README "Ray throughput"). Its vertex bookkeeping and MIS weights
// surround the same Embree queries, one at a time. The upper end: the pilot's grid rays cost more
// than a full iteration's (a lone pixel's paths, splats to the whole frame).
inline constexpr double kBdptRayCost = 1.8;

// What the automatic choice saw when it decided (reference.h's error estimate for one iteration,
// squared; rays per iteration of the whole image; photon mapping's rays apart), and the predicted
// cost (rays, BDPT's weighted by kBdptRayCost) of reaching the target with each.
struct PilotReport {
  bool ran = false;
  double pt_error2 = 0, bdpt_error2 = 0;
  double pt_rays = 0, bdpt_rays = 0, photon_rays = 0;
  double pt_cost = 0, bdpt_cost = 0;
  double seconds = 0;            // the pilot's own time (its bidirectional iterations on the grid)
  uint32_t iterations = 0;       // render iterations watched (path tracing's)
  uint32_t bdpt_iterations = 0;  // bidirectional iterations on the grid
  double pilot_rays = 0;  // the pilot's own rays, bidirectional ones weighted by kBdptRayCost
  double budget = 0;  // kPilotBudget of path tracing's predicted render, rays (at the last check)
  uint32_t dropped_iterations = 0;  // path tracing's, when bidirectional path tracing restarted
  // Why the render's estimator is the one it is, in words (the sidecar's `estimator_why`): the
  // rule of EstimatorPilot::step that decided, or why no pilot ran.
  std::string why;
  double pt_rays_per_iteration() const { return pt_rays + photon_rays; }
};

// Progressive photon mapping in its probabilistic form (Knaus & Zwicker 2011; README "Path space
// and the two estimators" and "Photon mapping's cost"), for the paths it owns.
struct PhotonMappingOptions {
  uint32_t photons = 50000;        // photon paths per photon pass (one pass an iteration)
  float alpha = 2.f / 3.f;         // the radius reduction (Knaus & Zwicker 2011, eq. 20)
  float radius = 0;                // the initial radius in metres; 0: radius_footprints below
  float radius_footprints = 1.5f;  // the initial radius in pixel footprints at the visible point
  // Point, spot and directional lights emit photons only towards texels of their emission domain
  // whose rays may reach a specular surface (README "Photon mapping's cost", aimed emission):
  // photon mapping keeps only photons whose first interaction was specular, so the others were
  // traced for nothing.
  bool aimed_emission = true;
};

}  // namespace pb::trace
