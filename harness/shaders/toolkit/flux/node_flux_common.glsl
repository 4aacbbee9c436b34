// pb::toolkit::NodeFlux's kernels (photonbench/toolkit/node_flux.h): per-node 64-bit fixed-point
// flux sums (toolkit/atomics.glsl) turned, after the splat, into floats in place (the low words
// take the float bits), for the occupied nodes of levels 0 to push.stop_level only: the estimate
// then reads 3 floats where it would read 6 words and convert them, per node and pixel.
#include "toolkit/atomics.glsl"
#define HIER_BINDING 0
#include "toolkit/hierarchy.glsl"
layout(std430, binding = 7) buffer FluxLo { uint flux_lo[]; };
layout(std430, binding = 8) readonly buffer FluxHi { uint flux_hi[]; };
// [0..2] the dispatch-indirect arguments of node_flux_resolve, [3] the nodes it covers.
layout(std430, binding = 9) buffer ResolveArgs { uint resolve_args[]; };

// Mirrors NodeFluxPush (harness/toolkit/src/node_flux.cpp).
layout(push_constant) uniform Push {
  vec4 watts_per_unit;  // xyz: per channel
  uint stop_level;      // levels 0 .. stop_level have sums
  uint words_per_node;  // 3 x groups (cluster: 3, directional: 24)
}
push;
