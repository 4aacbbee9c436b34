#version 460
// Box BVH build / morton (seed 003 §6.2): each box centre's 30-bit Morton code in the centres'
// bounds, with its item index, for the radix sort. Empty boxes take the last code.
#include "bvh_build.glsl"
layout(local_size_x = 256) in;
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.count) return;
  vec3 lo = vec3(pb_bvh_unordered(control[PB_BVH_CTL_MIN]),
                 pb_bvh_unordered(control[PB_BVH_CTL_MIN + 1u]),
                 pb_bvh_unordered(control[PB_BVH_CTL_MIN + 2u]));
  vec3 hi = vec3(pb_bvh_unordered(control[PB_BVH_CTL_MAX]),
                 pb_bvh_unordered(control[PB_BVH_CTL_MAX + 1u]),
                 pb_bvh_unordered(control[PB_BVH_CTL_MAX + 2u]));
  vec3 extent = max(hi - lo, vec3(1e-20));
  BvhBox b = boxes[i];
  keys[i] = pb_bvh_empty(b) ? 0x3fffffffu : pb_bvh_morton30((0.5 * (b.lo + b.hi) - lo) / extent);
  items[i] = i;
}
