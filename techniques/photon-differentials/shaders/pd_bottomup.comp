#version 460
// Pass "build" / bottom-up (seed 003 §5.2): internal node i joins its two children (box, first hit
// and hit count) once both are done: a leaf always is, an internal node from the dispatch after
// the one that joined it (visits = that dispatch's number, push.budget here), so no invocation
// reads what another writes in the same dispatch. The technique dispatches this 32 times: the
// radix tree over distinct 30-bit codes is at most 30 internal levels deep (each level's common
// prefix is longer than its parent's, and the root's is at least 2 bits). A node of at most T hits
// is a fused leaf (the query reads its whole range: "if their added hit counts are above the
// threshold, an inner node is built; otherwise, the two children ... are fused into one larger
// leaf"); this pass counts the inner nodes and the leaves directly below them.
//
// (The first version was one dispatch in which the second invocation to arrive at a node joins
// it, with Karras's atomic arrival counters. On lavapipe it joined about a fifth of the nodes,
// and the verify hook found boxes that missed their children. The cause was not pinned down; this
// version needs no ordering between invocations of one dispatch.)
#include "pd_common.glsl"
layout(local_size_x = 256) in;

bool done(uint node, uint runs, uint pass) {
  if (node >= runs - 1u) return true;  // a leaf
  uint v = nodes[node].visits;
  return v != 0u && v <= pass;
}

void main() {
  uint runs = control[PD_CTL_RUNS], threshold = control[PD_CTL_THRESHOLD];
  uint i = gl_GlobalInvocationID.x, pass = push.budget;  // this dispatch's number, from 1
  if (runs < 2u || i >= runs - 1u || nodes[i].visits != 0u) return;
  uint l = nodes[i].left, r = nodes[i].right;
  if (!done(l, runs, pass - 1u) || !done(r, runs, pass - 1u)) return;
  PdNode a = nodes[l], b = nodes[r];
  uint count = a.count + b.count;
  nodes[i].lo = min(a.lo, b.lo);
  nodes[i].hi = max(a.hi, b.hi);
  nodes[i].first = a.first;
  nodes[i].count = count;
  nodes[i].visits = pass;
  if (count > threshold) {
    atomicAdd(control[PD_CTL_INNER], 1u);
    uint leaves = (a.left == PD_NONE || a.count <= threshold ? 1u : 0u) +
                  (b.left == PD_NONE || b.count <= threshold ? 1u : 0u);
    atomicAdd(control[PD_CTL_LEAVES], leaves);
  }
}
