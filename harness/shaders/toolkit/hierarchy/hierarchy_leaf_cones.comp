#version 460
// cluster-build/cones, leaves (Paper I §4.5): "the maximum angle that a view sample's normal
// deviates from this average" -- each sample widens its leaf's half-angle (positive float bits
// order like the floats, so atomicMax on the bits is a float max).
#include "hierarchy_build.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
void main() {
  ivec2 pixel;
  if (!hier_pixel(pixel)) return;
  uint key = hier_sample_leaves[uint(pixel.y) * hier.frame.x + uint(pixel.x)];
  if (key == HIER_NO_LEAF) return;
  uint cid = hier_cid(hier_leaf_level(), key);
  vec3 n = normalize(mat3(hp.view) * imageLoad(gbuffer_normal, pixel).xyz);
  vec3 axis = vec3(uintBitsToFloat(hier_cone_words[cid * 4u]),
                   uintBitsToFloat(hier_cone_words[cid * 4u + 1u]),
                   uintBitsToFloat(hier_cone_words[cid * 4u + 2u]));
  float angle = acos(clamp(dot(n, axis), -1.0, 1.0));
  atomicMax(hier_cone_words[cid * 4u + 3u], floatBitsToUint(angle));
}
