#version 460
// Box BVH refit / leaves: leaf U - 1 + r takes the bounds the gather joined for run r (an empty
// box where none of its items has one), and inner node r (r < U - 1) is marked not joined, so
// that bvh_bottomup.comp's passes join the inner nodes again, one level a dispatch.
#include "bvh_refit.glsl"
layout(local_size_x = 256) in;
void main() {
  uint r = gl_GlobalInvocationID.x, runs = control[PB_BVH_CTL_RUNS];
  if (r >= runs) return;
  if (r + 1u < runs) nodes[r].visits = 0u;
  uint at = 6u * r, leaf = runs - 1u + r;
  if (refit_bounds[at] == 0xffffffffu) {  // no item of the run has a box: one that joins as none
    nodes[leaf].lo = vec3(3.0e38);
    nodes[leaf].hi = vec3(-3.0e38);
    return;
  }
  vec3 lo, hi;
  for (uint k = 0u; k < 3u; ++k) {
    lo[k] = pb_bvh_unordered(refit_bounds[at + k]);
    hi[k] = pb_bvh_unordered(~refit_bounds[at + 3u + k]);
  }
  nodes[leaf].lo = lo;
  nodes[leaf].hi = hi;
}
