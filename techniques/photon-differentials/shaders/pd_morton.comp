#version 460
// Pass "build" / morton (seed 003 §6.2): each hit's 30-bit Morton code in the hits' bounds, with
// its photon index, for the radix sort.
#include "pd_common.glsl"
layout(local_size_x = 256) in;
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.count) return;
  vec3 lo = vec3(pd_unordered(control[PD_CTL_MIN]), pd_unordered(control[PD_CTL_MIN + 1u]),
                 pd_unordered(control[PD_CTL_MIN + 2u]));
  vec3 hi = vec3(pd_unordered(control[PD_CTL_MAX]), pd_unordered(control[PD_CTL_MAX + 1u]),
                 pd_unordered(control[PD_CTL_MAX + 2u]));
  vec3 extent = max(hi - lo, vec3(1e-20));
  keys[i] = pd_morton30((photons[i].position - lo) / extent);
  values[i] = i;
}
