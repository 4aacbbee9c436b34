#version 460
// toolkit_test: adds push.count photon values (rgb watts, one per invocation) into one 64-bit
// fixed-point sum per channel with toolkit/atomics.glsl, as cluster's node flux and directional's
// buckets do: words 0-2 the low words, 3-5 the high words.
#include "toolkit/atomics.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Values { vec4 values[]; };
layout(std430, binding = 1) buffer Sums { uint sums[]; };
layout(push_constant) uniform Push {
  vec4 units_per_watt;
  uint count;
}
push;
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.count) return;
  uvec3 units = pb_flux_units(values[i].rgb, push.units_per_watt.xyz);
  PB_FLUX_ADD(sums, 0u, sums, 3u, units);
}
