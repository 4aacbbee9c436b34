#version 460
// Pass "accumulate" (Paper V §3.2): per stored photon a point walk of this frame's CP BVH (the
// paper's zero-length ray with an any-hit shader); every CP whose cylinder contains the hit, of
// the hit's material and facing the side the photon arrived from, adds the photon's flux to its
// sum, in fixed point with integer atomics: fixed64, the toolkit's 64-bit sums, or fixed4_28, the
// paper's 32-bit format (4 integer bits, 28 fractional) with its clamp at 15 (counted, saturated).
#include "cp_common.glsl"
layout(local_size_x = 64) in;

CpPhoton photon;
uint contributions = 0u, saturated = 0u;

bool pb_bvh_hit(uint item) {
  CpPoint c = points[item];
  if (c.material != photon.material || dot(photon.normal, c.normal) <= 0.0 ||
      !cp_in_cylinder(c, photon.position))
    return true;
  ++contributions;
  uint at = item * CP_ACCUM_WORDS;
  if (push.accumulator == CP_ACCUMULATOR_FIXED64) {
    PB_FLUX_ADD(accum, at, accum, at + 3u, pb_flux_units(photon.power, push.units_per_watt));
  } else {
    for (uint k = 0u; k < 3u; ++k) {
      float v = max(photon.power[k], 0.0);
      if (v > 15.0) ++saturated;
      uint u = uint(min(v, 15.0) * 268435456.0 + 0.5);
      if (u == 0u) continue;
      uint old = atomicAdd(accum[at + k], u);
      if (old + u < old) ++saturated;  // the 4 integer bits wrapped
    }
  }
  return true;  // IgnoreHit: every CP containing the hit is visited
}

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.photons) return;
  photon = photons[i];
  pb_bvh_budget = push.budget;
  bool complete = pb_bvh_point_walk(photon.position);
  PB_ADD64(stats, CP_STAT_BOXES_TESTED, pb_bvh_boxes_tested);
  PB_ADD64(stats, CP_STAT_NODES, pb_bvh_nodes_visited);
  PB_ADD64(stats, CP_STAT_CONTRIBUTIONS, contributions);
  if (saturated != 0u) atomicAdd(stats[CP_STAT_SATURATED], saturated);
  if (!complete) atomicAdd(stats[CP_STAT_TRUNCATED], 1u);
}
