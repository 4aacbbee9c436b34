#version 460
// Box BVH probe (BoxBvh::record_probe, a test hook): per query a point walk or a segment walk
// with push.leaf_size as the walk's pb_bvh_leaf_size and push.test_item_boxes as its
// pb_bvh_test_item_boxes, listing the items the any-hit hook was
// called for (at most push.per_query of them) and their number, so tests compare the walks with a
// brute-force search and their counts with a walk on the host.
layout(local_size_x = 64) in;
struct BvhProbeQuery {
  vec4 origin;     // xyz, w: 0 point walk, 1 segment walk
  vec4 direction;  // xyz, w: t1 (t0 = 0)
};
layout(std430, binding = 0) readonly buffer Queries { BvhProbeQuery queries[]; };
layout(std430, binding = 1) writeonly buffer Found { uint found[]; };
// per query two: (hits, complete, nodes popped, items of reached leaves), (nodes met, hook calls
// whose pb_bvh_slot did not hold the item, 0, 0)
layout(std430, binding = 2) writeonly buffer Counts { uvec4 counts[]; };
layout(push_constant) uniform Push {
  uint count, per_query, budget, leaf_size, test_item_boxes, pad0, pad1, pad2;
}
push;
#define PB_BVH_WALK_BINDING 3
uint query, hits, wrong_slots;
#include "bvh_walk.glsl"

bool pb_bvh_hit(uint item) {
  if (bvh_items[pb_bvh_slot] != item) ++wrong_slots;
  if (hits < push.per_query) found[query * push.per_query + hits] = item;
  ++hits;
  return true;
}

void main() {
  query = gl_GlobalInvocationID.x;
  if (query >= push.count) return;
  hits = 0u;
  wrong_slots = 0u;
  pb_bvh_test_item_boxes = push.test_item_boxes != 0u;
  pb_bvh_budget = push.budget;
  pb_bvh_leaf_size = push.leaf_size;
  BvhProbeQuery q = queries[query];
  bool complete = q.origin.w == 0.0
                      ? pb_bvh_point_walk(q.origin.xyz)
                      : pb_bvh_segment_walk(q.origin.xyz, q.direction.xyz, 0.0, q.direction.w);
  counts[2u * query] = uvec4(hits, complete ? 1u : 0u, pb_bvh_nodes_visited, pb_bvh_boxes_tested);
  counts[2u * query + 1u] = uvec4(pb_bvh_nodes_met, wrong_slots, 0u, 0u);
}
