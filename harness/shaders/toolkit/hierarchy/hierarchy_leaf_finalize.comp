#version 460
// cluster-build/leaf-bounds, second half: one invocation per occupied leaf turns the reduced words
// into floats in place (AABB min / max; with cones, the normalised average normal as the axis and a
// zero half-angle that hierarchy_leaf_cones then widens).
#include "hierarchy_build.glsl"
layout(local_size_x = 64) in;
void main() {
  uint leaf = hier_leaf_level();
  uint i = gl_GlobalInvocationID.x;
  if (i >= hier_count(leaf)) return;
  uint cid = hier_level_cid(leaf, i);
  for (uint k = 0u; k < 6u; ++k)
    hier_aabb_words[cid * 6u + k] = floatBitsToUint(hier_unorder(hier_aabb_words[cid * 6u + k]));
  if (hier_has_cones()) {
    vec3 sum = vec3(int(hier_cone_words[cid * 4u]), int(hier_cone_words[cid * 4u + 1u]),
                    int(hier_cone_words[cid * 4u + 2u]));
    vec3 axis = dot(sum, sum) > 0.0 ? normalize(sum) : vec3(0.0, 0.0, 1.0);
    for (uint k = 0u; k < 3u; ++k) hier_cone_words[cid * 4u + k] = floatBitsToUint(axis[k]);
    hier_cone_words[cid * 4u + 3u] = 0u;
  }
}
