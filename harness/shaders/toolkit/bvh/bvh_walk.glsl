// Walks of the toolkit's box BVH (photonbench/toolkit/box_bvh.h): a point walk (every item whose
// box contains a point) and a segment walk (every item whose box a segment meets), each calling
// an any-hit hook per item, in no defined order: a compute stand-in for DXR's any-hit shader over
// procedural AABBs (the point walk is Paper V's zero-length "point query" ray). The hook decides
// what the item's own primitive is (a cylinder, an ellipse) and whether the walk goes on.
//
// The including shader defines PB_BVH_WALK_BINDING (the first of four consecutive storage-buffer
// bindings: nodes, items, boxes, control; BoxBvh::walk_resources binds them), includes this, and
// defines
//   bool pb_bvh_hit(uint item)   the any-hit hook: false ends the walk (true: go on, "IgnoreHit")
// Budget: each node popped and each item box tested takes one unit of pb_bvh_budget (llvmpipe's
// loop limit), which the shader sets before a walk; a walk that runs out returns false.
// Leaf size: an inner node of at most pb_bvh_leaf_size items (0, the default: none) is walked as
// a leaf, its items' boxes tested in turn without descending: fewer nodes popped for more boxes
// tested (seed 003 §5.3's threshold T: "otherwise, the two children ... are fused into one larger
// leaf"), chosen per walk over the same tree.
// Item boxes: the walk tests an item's own box and calls the hook only when it meets the query;
// with pb_bvh_test_item_boxes false it calls the hook for every item of a leaf it reaches, for a
// hook whose own test is exact and cheaper than reading the box (photon-differentials' ellipsoid).
// In the hook, pb_bvh_slot is the item's place in the BVH's Morton order (BoxBvh::items()), so a
// caller that keeps a copy of its records in that order reads a leaf's records in sequence.
#ifndef PB_TOOLKIT_BVH_WALK_GLSL
#define PB_TOOLKIT_BVH_WALK_GLSL

#include "photonbench/toolkit/box_bvh_layout.h"

#ifndef PB_BVH_WALK_BINDING
#error "define PB_BVH_WALK_BINDING (the first of the walk's four bindings) first"
#endif

layout(std430, binding = PB_BVH_WALK_BINDING + 0) readonly buffer BvhNodes { BvhNode bvh_nodes[]; };
layout(std430, binding = PB_BVH_WALK_BINDING + 1) readonly buffer BvhItems { uint bvh_items[]; };
layout(std430, binding = PB_BVH_WALK_BINDING + 2) readonly buffer BvhBoxes { BvhBox bvh_boxes[]; };
layout(std430, binding = PB_BVH_WALK_BINDING + 3) readonly buffer BvhControl {
  uint bvh_control[];
};

bool pb_bvh_hit(uint item);

uint pb_bvh_budget = 0u;
uint pb_bvh_leaf_size = 0u;
bool pb_bvh_test_item_boxes = true;
uint pb_bvh_slot = 0u;
uint pb_bvh_nodes_visited = 0u;  // nodes popped by this invocation's walks
uint pb_bvh_nodes_met = 0u;      // of them, nodes whose box the point or segment met
uint pb_bvh_boxes_tested = 0u;   // items of reached leaves (their boxes tested, unless not asked)

#define PB_BVH_STACK 64u

bool pb_bvh_contains(vec3 lo, vec3 hi, vec3 x) {
  return all(greaterThanEqual(x, lo)) && all(lessThanEqual(x, hi));
}

// The segment origin + t direction, t in [t0, t1], meets the box (the slab test, with the
// direction's inverse; an axis the segment runs parallel to needs the origin inside that slab).
bool pb_bvh_meets(vec3 lo, vec3 hi, vec3 origin, vec3 direction, vec3 inverse_direction, float t0,
                  float t1) {
  // (No return inside the loop: lavapipe mis-ran returns from inside loops in these walks.)
  float enter = t0, leave = t1;
  bool outside = any(greaterThan(lo, hi));  // an empty box
  for (int k = 0; k < 3; ++k) {
    if (direction[k] == 0.0) {
      outside = outside || origin[k] < lo[k] || origin[k] > hi[k];
    } else {
      float a = (lo[k] - origin[k]) * inverse_direction[k];
      float b = (hi[k] - origin[k]) * inverse_direction[k];
      enter = max(enter, min(a, b));
      leave = min(leave, max(a, b));
    }
  }
  return !outside && enter <= leave;
}

// The walk: `segment` false tests boxes against the point `a`; true against the segment from a
// along direction d for t in [t0, t1]. False: the budget ran out, or the hook ended the walk
// (pb_bvh_stopped says which).
bool pb_bvh_stopped = false;
uint pb_bvh_stack[PB_BVH_STACK];
bool pb_bvh_walk(bool segment, vec3 a, vec3 d, float t0, float t1) {
  pb_bvh_stopped = false;
  if (bvh_control[PB_BVH_CTL_RUNS] == 0u) return true;
  vec3 inv = vec3(1.0) / d;  // inf on an axis d runs parallel to (pb_bvh_meets skips it)
  bool complete = true;
  uint top = 1u;
  pb_bvh_stack[0] = 0u;
  while (top > 0u && complete) {
    if (pb_bvh_budget == 0u) {
      complete = false;
      break;
    }
    --pb_bvh_budget;
    ++pb_bvh_nodes_visited;
    top -= 1u;
    BvhNode node = bvh_nodes[pb_bvh_stack[top]];
    bool in_box = segment ? pb_bvh_meets(node.lo, node.hi, a, d, inv, t0, t1)
                          : pb_bvh_contains(node.lo, node.hi, a);
    if (in_box) ++pb_bvh_nodes_met;
    if (in_box && node.left != PB_BVH_NONE && node.count > pb_bvh_leaf_size) {
      if (top + 2u > PB_BVH_STACK) {
        complete = false;
      } else {
        pb_bvh_stack[top] = node.right;
        pb_bvh_stack[top + 1u] = node.left;
        top += 2u;
      }
    } else if (in_box) {
      uint end = node.first + node.count;
      for (uint j = node.first; j < end; ++j) {
        if (pb_bvh_budget == 0u) {
          complete = false;
          break;
        }
        --pb_bvh_budget;
        ++pb_bvh_boxes_tested;
        uint item = bvh_items[j];
        bool hit = true;
        if (pb_bvh_test_item_boxes) {
          BvhBox b = bvh_boxes[item];
          hit = segment ? pb_bvh_meets(b.lo, b.hi, a, d, inv, t0, t1)
                        : pb_bvh_contains(b.lo, b.hi, a);
        }
        pb_bvh_slot = j;
        if (hit && !pb_bvh_hit(item)) {
          pb_bvh_stopped = true;
          complete = false;
          break;
        }
      }
    }
  }
  return complete;
}

// Every item whose box contains x.
bool pb_bvh_point_walk(vec3 x) { return pb_bvh_walk(false, x, vec3(1.0), 0.0, 0.0); }
// Every item whose box the segment origin + t direction, t in [t0, t1], meets.
bool pb_bvh_segment_walk(vec3 origin, vec3 direction, float t0, float t1) {
  return pb_bvh_walk(true, origin, direction, t0, t1);
}

#endif
