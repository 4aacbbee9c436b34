#version 460
// Box BVH build / runs: each run of equal Morton codes becomes leaf U - 1 + r, its box the union
// of its items' boxes by a loop over the run (seed 003 §6.2: "we omit the segmented scan ... and
// instead loop over each subset ... sharing a Morton code"); its code goes to the radix tree's
// keys.
#include "bvh_build.glsl"
layout(local_size_x = 256) in;
void main() {
  uint j = gl_GlobalInvocationID.x;
  if (j >= push.count || heads[j] == 0u) return;
  uint runs = control[PB_BVH_CTL_RUNS], r = run_index[j], code = keys[j];
  BvhBox b = boxes[items[j]];
  vec3 lo = b.lo, hi = b.hi;
  uint end = j + 1u, steps = 0u;
  while (end < push.count && keys[end] == code) {
    if (++steps >= push.budget) {  // llvmpipe's loop limit: the box stops growing, counted
      atomicAdd(control[PB_BVH_CTL_LONG_RUNS], 1u);
      while (end < push.count && keys[end] == code) end += 1u;  // (one comparison per step)
      break;
    }
    BvhBox c = boxes[items[end]];
    lo = min(lo, c.lo);
    hi = max(hi, c.hi);
    end += 1u;
  }
  BvhNode leaf;
  leaf.lo = lo;
  leaf.hi = hi;
  leaf.left = PB_BVH_NONE;
  leaf.right = PB_BVH_NONE;
  leaf.first = j;
  leaf.count = end - j;
  leaf.parent = PB_BVH_NONE;
  leaf.visits = 0u;
  nodes[runs - 1u + r] = leaf;
  unique_keys[r] = code;
}
