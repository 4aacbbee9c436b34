#version 460
// Box BVH build / bottom-up (seed 003 §5.2): internal node i joins its two children (box, first
// item and item count) once both are done: a leaf always is, an internal node from the dispatch
// after the one that joined it (visits = that dispatch's number, push.pass), so no invocation reads
// what another writes in the same dispatch. BoxBvh dispatches this 32 times: the radix tree over
// distinct 30-bit codes is at most 30 internal levels deep. (photon-differentials found a single
// dispatch with Karras's atomic arrival counters unreliable on lavapipe.)
#include "bvh_build.glsl"
layout(local_size_x = 256) in;

bool done(uint node, uint runs, uint pass) {
  if (node >= runs - 1u) return true;  // a leaf
  uint v = nodes[node].visits;
  return v != 0u && v <= pass;
}

void main() {
  uint runs = control[PB_BVH_CTL_RUNS];
  uint i = gl_GlobalInvocationID.x, pass = push.pass;
  if (runs < 2u || i >= runs - 1u || nodes[i].visits != 0u) return;
  uint l = nodes[i].left, r = nodes[i].right;
  if (!done(l, runs, pass - 1u) || !done(r, runs, pass - 1u)) return;
  BvhNode a = nodes[l], b = nodes[r];
  nodes[i].lo = min(a.lo, b.lo);
  nodes[i].hi = max(a.hi, b.hi);
  nodes[i].first = a.first;
  nodes[i].count = a.count + b.count;
  nodes[i].visits = pass;
  atomicAdd(control[PB_BVH_CTL_INNER], 1u);
}
