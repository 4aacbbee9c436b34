#version 460
// Pass "build" / tree (seed 003 §5.3, §6.2), after the toolkit's build: the footprints copied into
// the BVH's Morton order (the query's hook reads a leaf's in sequence, by the walk's
// pb_bvh_slot), and this frame's tree as the query walks it with leaf size T ("if their added hit
// counts are above the threshold, an inner node is built; otherwise, the two children ... are
// fused into one larger leaf"): the toolkit BVH's inner nodes of more than T hits, and the leaves
// (runs, or nodes of at most T hits) directly below them, counted.
#include "pd_common.glsl"
layout(std430, binding = PD_BVH_BINDING + 0) readonly buffer TreeNodes { BvhNode tree_nodes[]; };
layout(std430, binding = PD_BVH_BINDING + 1) readonly buffer TreeItems { uint tree_items[]; };
layout(std430, binding = PD_BVH_BINDING + 3) readonly buffer TreeControl { uint tree_control[]; };
layout(local_size_x = 256) in;

bool walked_as_leaf(BvhNode node, uint threshold) {
  return node.left == PB_BVH_NONE || node.count <= threshold;
}

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.count) return;
  sorted_footprints[i] = footprints[tree_items[i]];
  uint runs = tree_control[PB_BVH_CTL_RUNS], threshold = control[PD_CTL_THRESHOLD];
  if (runs < 2u || i >= runs - 1u) return;
  BvhNode node = tree_nodes[i];
  if (node.count <= threshold) return;
  atomicAdd(control[PD_CTL_INNER], 1u);
  uint leaves = (walked_as_leaf(tree_nodes[node.left], threshold) ? 1u : 0u) +
                (walked_as_leaf(tree_nodes[node.right], threshold) ? 1u : 0u);
  atomicAdd(control[PD_CTL_LEAVES], leaves);
}
