// Fixed-point flux sums: order-independent, exact integer accumulation of photon flux with 32-bit
// atomics (the harness's device enables no float atomics), for cluster's trivial-accept node flux
// (Paper I §4.6) and directional's buckets (§4.7). GPU side: toolkit/atomics.glsl.
//
// Scale, per channel c: units_per_watt[c] = 2^PB_FLUX_UNIT_BITS / (the largest value channel c
// takes over the frame's photons), so every photon's value is at most 2^26 units, and a weak
// channel (a photon's green at 1e-3 of its red) is resolved as finely as a strong one. Sums are
// 64-bit (a low word and a high word taking the carry: PB_FLUX_ADD), so nothing overflows below
// 2^38 adds.
//
// Error bound, per channel and per sum of n photon values v_1..v_n (watts, v_i <= max_c):
//   |sum read back - sum v_i| <= n * 0.5 * max_c / 2^26   (rounding each value to a whole unit)
//                               + 2^-22 * sum v_i          (float rounding: the scale and its
//                                                           inverse, each product v_i * scale,
//                                                           the read-back; half an ulp each)
// i.e. a relative error of at most 2^-22 + 2^-27 * max_c / mean(v_i), whatever the photon count.
// The old scale (the frame's total flux of the largest channel = 2^31 units) gave each photon
// 2^31 / N units of its strongest channel, so a channel at 1e-3 of it rounded to 2 units at 1e6
// photons and to 0 at 4e6; with Russian roulette most photons carry the same flux, so the rounding
// error was a bias, not noise.
#pragma once

#include <cstdint>
#include <glm/glm.hpp>
#include <span>

#include "photonbench/photons.h"
#include "photonbench/toolkit/limits.h"

namespace pb::toolkit {

struct FluxScale {
  glm::vec3 units_per_watt{1.0f};
  glm::vec3 watts_per_unit{1.0f};

  // The scale for sums of (shares of) these photons' power.
  static FluxScale for_photons(std::span<const trace::PhotonRecord> photons);
  // The scale for values no larger than `largest` per channel (0: that channel's scale is 1).
  static FluxScale for_largest(glm::vec3 largest);
  // A channel value in units, as pb_flux_units rounds it on the GPU.
  uint32_t units(float watts, int channel) const;
  // The bound above for n values of channel c whose sum is `sum` watts.
  double error_bound(uint64_t n, double sum, double largest) const;
};

}  // namespace pb::toolkit
