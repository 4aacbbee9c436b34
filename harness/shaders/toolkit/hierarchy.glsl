// The view-sample cluster hierarchy for shaders (Paper I §4.1, §4.3, §4.5, §5.2): buffer
// declarations and helpers shared by the cluster-build passes and by every shader that reads the
// hierarchy (cluster, directional). Layout and terms: photonbench/toolkit/hierarchy_layout.h; C++
// side: photonbench/toolkit/hierarchy.h; the traversal of a photon sphere: toolkit/traverse.glsl.
//
// Use: define HIER_BINDING to the first of HIER_BINDING_COUNT consecutive bindings (set 0), then
// include this file; bind pb::toolkit::Hierarchy::bindings() there in order:
//   HIER_BINDING + 0  info           HierInfo (hierarchy_layout.h)
//               + 1  masks[]        uint: roots' occupancy flags, child masks of levels 0..L-2,
//                                   leaf bases
//               + 2  slots[]        uint: key -> cid, dense per level but the leaves' (read where
//                                   occupied)
//               + 3  node_keys[]    uint: key of each cid (the per-level lists of occupied nodes)
//               + 4  aabbs[]        6 floats per cid: view-space min xyz, max xyz
//               + 5  cones[]        vec4 per cid: view-space cone axis xyz, half-angle w (radians)
//               + 6  sample_leaves[] uint per pixel: leaf key of the view sample, HIER_NO_LEAF if
//                                   none
// The build shaders define HIER_BUILD first: then the buffers are writable and aabbs / cones are
// seen as uint words (the build reduces into them with integer atomics).
#ifndef PB_TOOLKIT_HIERARCHY_GLSL
#define PB_TOOLKIT_HIERARCHY_GLSL

#include "photonbench/toolkit/hierarchy_layout.h"
#include "toolkit/constants.glsl"

#define HIER_BINDING_COUNT 7
#ifndef HIER_BINDING
#error "define HIER_BINDING (the first binding of the hierarchy's buffers) first"
#endif

#ifdef HIER_BUILD
#define HIER_RO
#else
#define HIER_RO readonly
#endif

layout(std430, binding = HIER_BINDING + 0) HIER_RO buffer HierInfoBuffer { HierInfo hier; };
layout(std430, binding = HIER_BINDING + 1) HIER_RO buffer HierMasks { uint hier_masks[]; };
layout(std430, binding = HIER_BINDING + 2) HIER_RO buffer HierSlots { uint hier_slots[]; };
layout(std430, binding = HIER_BINDING + 3) HIER_RO buffer HierNodeKeys { uint hier_node_keys[]; };
#ifdef HIER_BUILD
layout(std430, binding = HIER_BINDING + 4) buffer HierAabbs { uint hier_aabb_words[]; };
layout(std430, binding = HIER_BINDING + 5) buffer HierCones { uint hier_cone_words[]; };
#else
layout(std430, binding = HIER_BINDING + 4) readonly buffer HierAabbs { float hier_aabbs[]; };
layout(std430, binding = HIER_BINDING + 5) readonly buffer HierCones { vec4 hier_cones[]; };
#endif
layout(std430, binding = HIER_BINDING + 6) HIER_RO buffer HierSampleLeaves {
  uint hier_sample_leaves[];
};

// Margin (radians) on normal-cone decisions: cone angles come from float acos and fixed-point
// normal sums, so a decision within this margin of the boundary is left to the exact per-sample
// test.
const float HIER_CONE_EPS = 2e-3;

uint hier_levels() { return hier.dims.x; }
uint hier_leaf_level() { return hier.dims.x - 1u; }
uint hier_root_count() { return hier.dims.w; }

// Node keys (Paper I §4.3: "the node key is simply shifted five bits to the left, and i is
// appended").
uint hier_child_key(uint key, uint i) { return (key << 5u) | i; }
uint hier_parent_key(uint key) { return key >> 5u; }

// Occupied nodes of a level this frame, and the i-th of them (its cid; its key is hier_key(cid)).
uint hier_count(uint level) { return hier.counts[level]; }
uint hier_level_cid(uint level, uint i) { return hier.level[level].z + i; }
uint hier_cid_capacity() {
  uint last = hier_leaf_level();
  return hier.level[last].z + hier.level[last].w;
}
// Child mask of an occupied inner node (level < L-1): bit i set when child i holds view samples.
uint hier_mask(uint level, uint key) { return hier_masks[hier.level[level].x + key]; }
// Compact id of an occupied node (valid only where the parent's mask bit, or for a root the level-0
// list, says the node is occupied this frame: stale map entries are never cleared). Inner nodes:
// the dense key -> cid map; leaves (Paper I §5.2: "to reduce the memory footprint" at the final
// level): the parent's leaf base + the rank of the leaf's bit in the parent's child mask.
uint hier_cid(uint level, uint key) {
  if (level + 1u < hier_levels()) return hier_slots[hier.level[level].y + key];
  uint parent = hier_parent_key(key);
  uint parent_cid = hier_slots[hier.level[level - 1u].y + parent];
  uint base = hier_masks[hier.level[level].x + parent_cid - hier.level[level - 1u].z];
  uint below = hier_masks[hier.level[level - 1u].x + parent] & ((1u << (key & 31u)) - 1u);
  return base + uint(bitCount(below));
}
uint hier_level_of_cid(uint cid) {
  uint level = 0u;
  while (level + 1u < hier_levels() && cid >= hier.level[level + 1u].z) ++level;
  return level;
}

#ifndef HIER_BUILD
uint hier_key(uint cid) { return hier_node_keys[cid]; }
void hier_aabb(uint cid, out vec3 lo, out vec3 hi) {
  uint b = cid * 6u;
  lo = vec3(hier_aabbs[b], hier_aabbs[b + 1u], hier_aabbs[b + 2u]);
  hi = vec3(hier_aabbs[b + 3u], hier_aabbs[b + 4u], hier_aabbs[b + 5u]);
}
// Normal cone of a node (only built when the hierarchy has HIER_FLAG_CONES): xyz the view-space
// axis, w the half-angle alpha (Paper I §4.5).
vec4 hier_cone(uint cid) { return hier_cones[cid]; }
uint hier_sample_leaf(ivec2 pixel) {
  return hier_sample_leaves[uint(pixel.y) * hier.frame.x + uint(pixel.x)];
}
#endif

bool hier_has_cones() { return (hier.grid.w & HIER_FLAG_CONES) != 0u; }

// Sphere (view-space centre c, radius r) against an AABB: intersects when the closest point of the
// box is within r; encloses when the farthest corner is (Paper I §4.3, the digest's reading).
bool hier_sphere_intersects(vec3 lo, vec3 hi, vec3 c, float r) {
  vec3 d = max(max(lo - c, c - hi), vec3(0.0));
  return dot(d, d) <= r * r;
}
bool hier_sphere_encloses(vec3 lo, vec3 hi, vec3 c, float r) {
  vec3 d = max(abs(c - lo), abs(c - hi));
  return dot(d, d) <= r * r;
}

// Normal-cone tests (Paper I §4.5, §4.6) for a photon arriving from view-space unit direction w_in
// (pointing away from the surface, towards where the photon came from, i.e. -direction of travel):
// reject when the angle to the cone axis exceeds pi/2 + alpha (below every contained tangent
// plane); "all above" when it is under pi/2 - alpha (above every contained tangent plane).
float hier_cone_angle(vec4 cone, vec3 w_in) { return acos(clamp(dot(cone.xyz, w_in), -1.0, 1.0)); }
bool hier_cone_rejects(vec4 cone, vec3 w_in) {
  return hier_cone_angle(cone, w_in) > PB_HALF_PI + cone.w + HIER_CONE_EPS;
}
bool hier_cone_all_above(vec4 cone, vec3 w_in) {
  return hier_cone_angle(cone, w_in) < PB_HALF_PI - cone.w - HIER_CONE_EPS;
}

// Depth slice of a view depth (metres along the viewing axis): exponential slices (Olsson et al.'s
// clustered shading, so leaves are roughly cubical), slice 0 starting at depth `near`, each slice q
// times deeper than the previous (inv_ln_q = 1 / ln q). cluster-build stores the frame's values in
// hier.depth.zw.
uint hier_depth_slice_at(float view_depth, float near, float inv_ln_q) {
  float s = floor(log(max(view_depth, near) / near) * inv_ln_q);
  return uint(clamp(s, 0.0, float(hier.grid.z - 1u)));
}

// Leaf key of the view sample at `pixel` with view depth `view_depth`: the leaf-grid cell (pixel /
// leaf block, depth slice) spelled out level by level, root first.
uint hier_leaf_key_at(uvec2 pixel, float view_depth, float near, float inv_ln_q) {
  uvec3 g = uvec3(pixel.x / hier.frame.z, pixel.y / hier.frame.w,
                  hier_depth_slice_at(view_depth, near, inv_ln_q));
  uvec3 top = hier.divisor[0].xyz * hier.split[0].xyz;  // leaf cells per root
  uint key = (g.y / top.y) * hier.dims.y + g.x / top.x;
  for (uint l = 0u; l + 1u < hier_levels(); ++l) {
    uvec3 c = (g / hier.divisor[l].xyz) % hier.split[l].xyz;
    key = hier_child_key(key, c.x + hier.split[l].x * (c.y + hier.split[l].y * c.z));
  }
  return key;
}

#ifndef HIER_BUILD
// The same with this frame's slicing (after cluster-build): the leaf a view sample falls in, from
// which a shader walks to the sample's containing nodes with hier_parent_key.
uint hier_leaf_key(uvec2 pixel, float view_depth) {
  return hier_leaf_key_at(pixel, view_depth, uintBitsToFloat(hier.depth.z),
                          uintBitsToFloat(hier.depth.w));
}
#endif

#endif  // PB_TOOLKIT_HIERARCHY_GLSL
