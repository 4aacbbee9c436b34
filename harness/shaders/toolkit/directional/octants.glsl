// The eight direction buckets of Paper I §4.7: "we store the flux incoming from each octant of the
// sphere", in view space. A photon's bucket is the sign pattern of its incident direction w =
// -(direction of travel), the direction it came from, in view coordinates: bit 0 set when w.x < 0,
// bit 1 when w.y < 0, bit 2 when w.z < 0. An octant's representative direction is its centre (+-1,
// +-1, +-1) / sqrt(3) (the paper does not name one; digest §4 [GAP]).
#ifndef PB_TOOLKIT_OCTANTS_GLSL
#define PB_TOOLKIT_OCTANTS_GLSL

#include "toolkit/constants.glsl"

uint octant_of(vec3 w) {
  return (w.x < 0.0 ? 1u : 0u) | (w.y < 0.0 ? 2u : 0u) | (w.z < 0.0 ? 4u : 0u);
}

vec3 octant_signs(uint o) {
  return vec3((o & 1u) != 0u ? -1.0 : 1.0, (o & 2u) != 0u ? -1.0 : 1.0,
              (o & 4u) != 0u ? -1.0 : 1.0);
}

// Paper I's heuristic: "The contribution from each direction is simply weighted with 2cos(n,d) ...
// We multiply by 2 to account for that the integral of the cosine is smaller (pi) than the integral
// of the hemisphere (2pi)." Negative cosines (octants behind the tangent plane) weigh 0.
float octant_weight_cos2(vec3 n, uint o) {
  return max(0.0, 2.0 * dot(n, octant_signs(o)) * 0.57735026919);
}

// The weight Paper I describes as the exact correction and replaces by the heuristic: the share of
// the octant's solid angle that lies above the tangent plane of normal n (the paper suggests a
// small cubemap of these; here 8x8 directions uniform in solid angle per octant, z and azimuth
// stratified: Archimedes' theorem makes z uniform on the sphere). On an axis-aligned surface it is
// exactly 1 or 0 per octant, so the estimate equals the tangent-plane test of the list-based
// methods there.
void octant_weights_clip(vec3 n, out float weights[8]) {
  for (uint o = 0u; o < 8u; ++o) weights[o] = 0.0;
  for (uint i = 0u; i < 64u; ++i) {
    float z = (float(i >> 3u) + 0.5) / 8.0;
    float phi = (float(i & 7u) + 0.5) / 8.0 * PB_HALF_PI;
    float s = sqrt(1.0 - z * z);
    vec3 d = vec3(s * cos(phi), s * sin(phi), z);
    for (uint o = 0u; o < 8u; ++o)
      if (dot(n, octant_signs(o) * d) > 0.0) weights[o] += 1.0 / 64.0;
  }
}

#endif
