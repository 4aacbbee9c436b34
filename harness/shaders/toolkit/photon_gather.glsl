// Paper I's radiance estimate over photon lists (§4.4, shared by tiled and cluster): a photon in a
// sample's lists contributes when the sample lies inside its sphere and the photon arrives from
// above the sample's tangent plane (implied by §4.6); I = f * sum(Phi) with the Lambertian f =
// albedo / pi (every estimate here is diffuse: photons are stored on diffuse surfaces only), L = I
// / (pi r^2) (constant kernel, no smoothing). Lists are read in slices of PB_LIST_SLICE entries,
// one dispatch each (llvmpipe's loop limit; pb::toolkit::dispatch_slices), later slices adding to
// the image; a work group sums the entries it read and rejected and adds them to two 64-bit
// counters once.
//
// Use: declare `PhotonRecord photons[]`, include toolkit/photon_lists.glsl, then this.
#ifndef PB_TOOLKIT_PHOTON_GATHER_GLSL
#define PB_TOOLKIT_PHOTON_GATHER_GLSL

#include "toolkit/atomics.glsl"
#include "toolkit/constants.glsl"

// Entries [lo, hi) of the list that starts at `begin` of pb_lists: accepted photons' flux into
// `flux`; returns how many were accepted.
uint pb_gather(uint begin, uint lo, uint hi, vec3 x, vec3 n, float r2, inout vec3 flux) {
  uint accepted = 0u;
  for (uint k = lo; k < hi; ++k) {
    PhotonRecord ph = photons[pb_lists[begin + k]];
    vec3 d = ph.position - x;
    if (dot(d, d) <= r2 && dot(n, ph.direction) < 0.0) {
      flux += ph.power;
      ++accepted;
    }
  }
  return accepted;
}

// The part of this dispatch's slice [first, first + PB_LIST_SLICE) of a sample's concatenated lists
// that falls in one list occupying [base, base + length) of them, as indices into that list.
uvec2 pb_slice_of(uint base, uint length, uint first) {
  uint lo = max(first, base), hi = min(first + PB_LIST_SLICE, base + length);
  return hi > lo ? uvec2(lo - base, hi - base) : uvec2(0u);
}

vec3 pb_lambert_radiance(vec3 albedo, vec3 flux, float r2) {
  return albedo / PB_PI * flux / (PB_PI * r2);
}

shared uint pb_group_read, pb_group_rejected;
void pb_gather_group_begin() {
  if (gl_LocalInvocationIndex == 0u) {
    pb_group_read = 0u;
    pb_group_rejected = 0u;
  }
  barrier();
}
void pb_gather_tally(uint read, uint accepted) {
  if (read == 0u) return;
  atomicAdd(pb_group_read, read);
  atomicAdd(pb_group_rejected, read - accepted);
}
// At the end of main, reached by every invocation of the group.
#define PB_GATHER_GROUP_END(stats, read_at, rejected_at) \
  {                                                      \
    barrier();                                           \
    if (gl_LocalInvocationIndex == 0u) {                 \
      PB_ADD64(stats, read_at, pb_group_read);           \
      PB_ADD64(stats, rejected_at, pb_group_rejected);   \
    }                                                    \
  }

#endif
