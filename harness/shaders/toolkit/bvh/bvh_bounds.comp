#version 460
// Box BVH build / bounds: the non-empty boxes' centres' bounds (for the Morton codes), reduced in
// the group, then with atomics on order-preserving float bits.
#include "bvh_build.glsl"
layout(local_size_x = 256) in;
shared uint group_min[3], group_max[3];
void main() {
  uint id = gl_LocalInvocationID.x, i = gl_GlobalInvocationID.x;
  if (id < 3u) group_min[id] = 0xffffffffu, group_max[id] = 0u;
  barrier();
  if (i < push.count && !pb_bvh_empty(boxes[i])) {
    vec3 c = 0.5 * (boxes[i].lo + boxes[i].hi);
    for (uint k = 0u; k < 3u; ++k) {
      atomicMin(group_min[k], pb_bvh_ordered(c[k]));
      atomicMax(group_max[k], pb_bvh_ordered(c[k]));
    }
  }
  barrier();
  if (id < 3u) {
    atomicMin(control[PB_BVH_CTL_MIN + id], group_min[id]);
    atomicMax(control[PB_BVH_CTL_MAX + id], group_max[id]);
  }
}
