// What a reference render is asked for: its stop rules, its path-space truncation, the unbiased
// estimator and photon mapping's settings (reference.h renders with these). Below the renderer's
// passes, so that each of them can read what it needs.
#pragma once

#include <cstdint>

#include "reference/estimators.h"

namespace pb::trace {

// One iteration renders one camera sample per pixel with the unbiased estimator and, where photon
// mapping has work (a scene with specular surfaces and a wanted class it feeds), one photon pass;
// the iteration's image is one independent, identically seeded-apart estimate of the frame, so
// the mean, its variance and the two halves (reference.h, ReferenceImage) all come from the
// spread of iteration images.
struct ReferenceOptions {
  // Stop rules: the render ends at the first one reached; 0 turns a rule off, at least one is on.
  float rel_error = 0;     // estimated relative RMS error of the mean (reference.h, error estimate)
  double max_seconds = 0;  // wall-clock seconds (the image is as good as the iterations done)
  uint32_t samples = 256;  // iterations (camera samples per pixel); 0 (off) or at least 2
  uint32_t min_samples = 16;  // the error estimate is trusted from this many iterations on
  // Scattering vertices on a full path between camera and emitter (C L: 0, C D L: 1, ...); 0:
  // untruncated. A photon technique's `max_bounces: B` matches max_bounces = B
  // (bounces_matching_photon_technique).
  uint32_t max_bounces = 0;
  PhotonMappingOptions photon_mapping;
  Estimator estimator = Estimator::automatic;
  LightStrategies light_strategies = LightStrategies::mis;  // pt only
  MisHeuristic mis_heuristic = MisHeuristic::power;         // bdpt only
  LightSelection light_selection = LightSelection::power;   // pt's next-event estimation
  uint32_t seed = 1;
  int threads = 0;  // 0: all cores

  // Throws pb::InputError naming the stop rule at fault: samples 1 (one iteration has no variance
  // and an empty odd half), or every rule off (nothing would stop the render). The config's
  // reference block and `photonbench reference` are checked by the same rule
  // (config::stop_rule_problem).
  void validate() const;
};

}  // namespace pb::trace
