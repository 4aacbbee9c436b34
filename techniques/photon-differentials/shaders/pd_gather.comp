#version 460
// Pass "build" / gather: the footprints in Morton order, and a 1 where a run of equal codes (the
// candidate leaves, "subsets [that] cannot be split further", §6.2) starts.
#include "pd_common.glsl"
layout(local_size_x = 256) in;
void main() {
  uint j = gl_GlobalInvocationID.x;
  if (j >= push.count) return;
  sorted_footprints[j] = footprints[values[j]];
  heads[j] = (j == 0u || keys[j] != keys[j - 1u]) ? 1u : 0u;
}
