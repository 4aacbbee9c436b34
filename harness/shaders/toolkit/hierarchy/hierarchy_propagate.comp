#version 460
// cluster-build/propagate (Paper I §4.1 Fig. 3 "bounds ... propagated upwards", §4.5 Fig. 4): one
// invocation per occupied node of level hp.level (dispatched from the level above the leaves up to
// the roots) unites its occupied children's AABBs and, with cones, sets the axis to the normalised
// average of the children's axes and the half-angle to max over children of (angle between the
// child's axis and this axis + the child's half-angle).
#include "hierarchy_build.glsl"
layout(local_size_x = 64) in;
vec3 cone_axis(uint cid) {
  return vec3(uintBitsToFloat(hier_cone_words[cid * 4u]),
              uintBitsToFloat(hier_cone_words[cid * 4u + 1u]),
              uintBitsToFloat(hier_cone_words[cid * 4u + 2u]));
}
void main() {
  uint level = hp.level;
  uint i = gl_GlobalInvocationID.x;
  if (i >= hier_count(level)) return;
  uint cid = hier_level_cid(level, i);
  uint key = hier_node_keys[cid];
  uint mask = hier_mask(level, key);
  vec3 lo = vec3(3.0e38), hi = vec3(-3.0e38), sum = vec3(0.0);
  for (uint m = mask; m != 0u; m &= m - 1u) {
    uint child = hier_cid(level + 1u, hier_child_key(key, uint(findLSB(m))));
    for (uint k = 0u; k < 3u; ++k) {
      lo[k] = min(lo[k], uintBitsToFloat(hier_aabb_words[child * 6u + k]));
      hi[k] = max(hi[k], uintBitsToFloat(hier_aabb_words[child * 6u + 3u + k]));
    }
    if (hier_has_cones()) sum += cone_axis(child);
  }
  for (uint k = 0u; k < 3u; ++k) {
    hier_aabb_words[cid * 6u + k] = floatBitsToUint(lo[k]);
    hier_aabb_words[cid * 6u + 3u + k] = floatBitsToUint(hi[k]);
  }
  if (hier_has_cones()) {
    vec3 axis = dot(sum, sum) > 1e-12 ? normalize(sum) : vec3(0.0, 0.0, 1.0);
    float alpha = 0.0;
    for (uint m = mask; m != 0u; m &= m - 1u) {
      uint child = hier_cid(level + 1u, hier_child_key(key, uint(findLSB(m))));
      float deviation = acos(clamp(dot(cone_axis(child), axis), -1.0, 1.0));
      alpha = max(alpha, deviation + uintBitsToFloat(hier_cone_words[child * 4u + 3u]));
    }
    alpha = min(alpha, PB_PI);
    for (uint k = 0u; k < 3u; ++k) hier_cone_words[cid * 4u + k] = floatBitsToUint(axis[k]);
    hier_cone_words[cid * 4u + 3u] = floatBitsToUint(alpha);
  }
}
