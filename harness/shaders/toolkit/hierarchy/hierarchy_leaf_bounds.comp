#version 460
// cluster-build/leaf-bounds (Paper I §4.1, Fig. 3 "bounds"): each view sample grows its leaf's
// view-space AABB (order-preserving uint atomics) and, with normal cones, adds its view-space
// normal to the leaf's fixed-point normal sum (Paper I §4.5: the cone axis is the average normal).
#include "hierarchy_build.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
void main() {
  ivec2 pixel;
  if (!hier_pixel(pixel)) return;
  uint key = hier_sample_leaves[uint(pixel.y) * hier.frame.x + uint(pixel.x)];
  if (key == HIER_NO_LEAF) return;
  uint cid = hier_cid(hier_leaf_level(), key);
  vec3 p = (hp.view * vec4(imageLoad(gbuffer_position, pixel).xyz, 1.0)).xyz;
  for (uint k = 0u; k < 3u; ++k) {
    uint u = hier_order(p[k]);
    atomicMin(hier_aabb_words[cid * 6u + k], u);
    atomicMax(hier_aabb_words[cid * 6u + 3u + k], u);
  }
  if (hier_has_cones()) {
    vec3 n = normalize(mat3(hp.view) * imageLoad(gbuffer_normal, pixel).xyz);
    for (uint k = 0u; k < 3u; ++k)
      atomicAdd(hier_cone_words[cid * 4u + k], uint(int(round(n[k] * float(hp.normal_scale)))));
  }
}
