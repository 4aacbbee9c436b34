#version 460
// Box BVH refit / gather: the build's Morton order kept, each item's new box joins the bounds of
// the leaf it was sorted into (its run: the heads scan counts the runs started before it, its own
// head included once heads[j] is added back) with atomics. Atomics, not bvh_runs.comp's loop over
// a run: every item counts, however long its run (a build puts all empty boxes into one run, and
// a refit may fill them), so no leaf is cut short by the loop budget.
#include "bvh_refit.glsl"
layout(local_size_x = 256) in;
void main() {
  uint j = gl_GlobalInvocationID.x;
  if (j >= push.count) return;
  BvhBox b = boxes[items[j]];
  if (pb_bvh_empty(b)) return;
  uint at = 6u * (run_index[j] + heads[j] - 1u);
  for (uint k = 0u; k < 3u; ++k) {
    atomicMin(refit_bounds[at + k], pb_bvh_ordered(b.lo[k]));
    atomicMin(refit_bounds[at + 3u + k], ~pb_bvh_ordered(b.hi[k]));
  }
}
