// Exact integer accumulation with 32-bit atomics (the harness's device enables no float or 64-bit
// atomics): 64-bit counters as two words, and the fixed-point flux sums of
// photonbench/toolkit/fixed_point.h. GLSL cannot pass a buffer to a function, so the adds are
// macros over any `uint` array.
#ifndef PB_TOOLKIT_ATOMICS_GLSL
#define PB_TOOLKIT_ATOMICS_GLSL

#include "photonbench/toolkit/limits.h"

// words[at] += value as the low word of a 64-bit counter; its carry goes to words[at + 1].
#define PB_ADD64(words, at, value)                                    \
  {                                                                   \
    uint pb_v_ = (value);                                             \
    if (pb_v_ != 0u) {                                                \
      uint pb_old_ = atomicAdd(words[at], pb_v_);                     \
      if (pb_old_ + pb_v_ < pb_old_) atomicAdd(words[(at) + 1u], 1u); \
    }                                                                 \
  }

// Fixed point (fixed_point.h): watts -> units of channel c, round(phi * units_per_watt), at most
// 2^PB_FLUX_UNIT_BITS for the frame's largest photon value, so one 32-bit add never wraps twice.
uvec3 pb_flux_units(vec3 phi, vec3 units_per_watt) {
  return uvec3(round(max(phi, vec3(0.0)) * units_per_watt));
}

// Adds `units` (uvec3) to three 64-bit sums: channel c's low word at lo[lo_at + c], its high word
// at hi[hi_at + c] (lo and hi may be one array). The high word only changes on a carry, i.e. about
// once per 2^(32 - PB_FLUX_UNIT_BITS) adds of the largest photon.
#define PB_FLUX_ADD(lo, lo_at, hi, hi_at, units)                           \
  {                                                                        \
    uvec3 pb_u_ = (units);                                                 \
    for (uint pb_c_ = 0u; pb_c_ < 3u; ++pb_c_) {                           \
      uint pb_w_ = pb_u_[pb_c_];                                           \
      if (pb_w_ != 0u) {                                                   \
        uint pb_old_ = atomicAdd(lo[(lo_at) + pb_c_], pb_w_);              \
        if (pb_old_ + pb_w_ < pb_old_) atomicAdd(hi[(hi_at) + pb_c_], 1u); \
      }                                                                    \
    }                                                                      \
  }

// The watts a 64-bit sum of units (low word, high word) stands for.
float pb_flux_watts(uint lo, uint hi, float watts_per_unit) {
  return (float(hi) * 4294967296.0 + float(lo)) * watts_per_unit;
}

#endif
