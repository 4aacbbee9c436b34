#version 460
// Box BVH build / heads: a 1 where a run of equal Morton codes (a leaf, "subsets [that] cannot be
// split further", seed 003 §6.2) starts in the sorted keys.
#include "bvh_build.glsl"
layout(local_size_x = 256) in;
void main() {
  uint j = gl_GlobalInvocationID.x;
  if (j >= push.count) return;
  heads[j] = (j == 0u || keys[j] != keys[j - 1u]) ? 1u : 0u;
}
