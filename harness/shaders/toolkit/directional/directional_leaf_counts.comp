#version 460
// splat/leaf-counts: for each leaf (the children of the accumulation level), the number of its view
// samples and the sum of their view-space positions, the weights and centres of the coverage
// estimate (directional_splat.glsl). Integer atomics only (the device enables no float atomics): a
// position is summed as its offset in the leaf's AABB in units of 1/4096 of the box, so 2^20
// samples per leaf fit the 32-bit words. Four words per leaf (by cid - first leaf cid): count, x,
// y, z.
#define PB_PROFILE_SLOT 0u
#include "directional_common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (!pb_in_frame(pixel, push.limits.yz)) return;
  uint leaf = hier_sample_leaf(pixel);
  if (leaf == HIER_NO_LEAF) return;
  uint cid = hier_cid(hier_leaf_level(), leaf);
  vec3 lo, hi;
  hier_aabb(cid, lo, hi);
  vec3 p = (push.view * vec4(imageLoad(gbuffer_position, pixel).xyz, 1.0)).xyz;
  uvec3 q = uvec3(clamp((p - lo) / max(hi - lo, vec3(1e-12)), 0.0, 1.0) * DIR_CENTROID_SCALE);
  uint at = 4u * (cid - hier.level[hier_leaf_level()].z);
  atomicAdd(leaf_stats[at], 1u);
  atomicAdd(leaf_stats[at + 1u], q.x);
  atomicAdd(leaf_stats[at + 2u], q.y);
  atomicAdd(leaf_stats[at + 3u], q.z);
}
