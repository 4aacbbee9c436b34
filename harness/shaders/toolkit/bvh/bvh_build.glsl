// The box BVH build's one binding list and push block (every build pass declares all of them, so
// BoxBvh binds one resource list), and its Morton helpers. Moved from photon-differentials' build
// (seed 003 §6.2), made to take any boxes.
#ifndef PB_TOOLKIT_BVH_BUILD_GLSL
#define PB_TOOLKIT_BVH_BUILD_GLSL

#include "photonbench/toolkit/box_bvh_layout.h"

layout(std430, binding = 0) readonly buffer Boxes { BvhBox boxes[]; };  // item order
layout(std430, binding = 1) buffer Keys { uint keys[]; };    // Morton codes (sorted in place)
layout(std430, binding = 2) buffer Items { uint items[]; };  // item index of each key
layout(std430, binding = 3) buffer Heads { uint heads[]; };  // 1 where a run of a code starts
layout(std430, binding = 4) buffer RunIndex { uint run_index[]; };      // exclusive scan of heads
layout(std430, binding = 5) buffer UniqueKeys { uint unique_keys[]; };  // code of each run
layout(std430, binding = 6) coherent buffer Nodes { BvhNode nodes[]; };
layout(std430, binding = 7) coherent buffer Control { uint control[]; };

layout(push_constant) uniform Push { BvhPush push; };

// Floats as uints whose unsigned order is the floats' order (for atomicMin / atomicMax).
uint pb_bvh_ordered(float f) {
  uint b = floatBitsToUint(f);
  return (b & 0x80000000u) != 0u ? ~b : (b | 0x80000000u);
}
float pb_bvh_unordered(uint u) {
  return uintBitsToFloat((u & 0x80000000u) != 0u ? (u & 0x7fffffffu) : ~u);
}

// 10 bits of each axis interleaved: x in the highest of each triple.
uint pb_bvh_expand_bits(uint v) {
  v = (v * 0x00010001u) & 0xFF0000FFu;
  v = (v * 0x00000101u) & 0x0F00F00Fu;
  v = (v * 0x00000011u) & 0xC30C30C3u;
  v = (v * 0x00000005u) & 0x49249249u;
  return v;
}
uint pb_bvh_morton30(vec3 unit) {
  uvec3 q = uvec3(clamp(unit * 1024.0, vec3(0.0), vec3(1023.0)));
  return pb_bvh_expand_bits(q.x) * 4u + pb_bvh_expand_bits(q.y) * 2u + pb_bvh_expand_bits(q.z);
}

bool pb_bvh_empty(BvhBox b) { return any(greaterThan(b.lo, b.hi)); }

#endif
