#version 460
// Box BVH probe (BoxBvh::record_probe, a test hook): per query a point walk or a segment walk,
// listing the items the any-hit hook was called for (at most push.per_query of them) and their
// number, so tests compare the walks with a brute-force search.
layout(local_size_x = 64) in;
struct BvhProbeQuery {
  vec4 origin;     // xyz, w: 0 point walk, 1 segment walk
  vec4 direction;  // xyz, w: t1 (t0 = 0)
};
layout(std430, binding = 0) readonly buffer Queries { BvhProbeQuery queries[]; };
layout(std430, binding = 1) writeonly buffer Found { uint found[]; };
// hits, complete, nodes popped, item boxes tested
layout(std430, binding = 2) writeonly buffer Counts { uvec4 counts[]; };
layout(push_constant) uniform Push { uint count, per_query, budget, pad; }
push;
#define PB_BVH_WALK_BINDING 3
uint query, hits;
#include "bvh_walk.glsl"

bool pb_bvh_hit(uint item) {
  if (hits < push.per_query) found[query * push.per_query + hits] = item;
  ++hits;
  return true;
}

void main() {
  query = gl_GlobalInvocationID.x;
  if (query >= push.count) return;
  hits = 0u;
  pb_bvh_budget = push.budget;
  BvhProbeQuery q = queries[query];
  bool complete = q.origin.w == 0.0
                      ? pb_bvh_point_walk(q.origin.xyz)
                      : pb_bvh_segment_walk(q.origin.xyz, q.direction.xyz, 0.0, q.direction.w);
  counts[query] = uvec4(hits, complete ? 1u : 0u, pb_bvh_nodes_visited, pb_bvh_boxes_tested);
}
