#version 460
// cluster-build/depth-range: nearest and farthest view depth of the frame's view samples, the range
// the exponential depth slices span (hier.depth.xy). 8x8 groups reduce in shared memory first.
#include "hierarchy_build.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
shared uint group_min, group_max;
void main() {
  if (gl_LocalInvocationIndex == 0u) {
    group_min = 0x7f800000u;
    group_max = 0u;
  }
  barrier();
  ivec2 pixel;
  if (hier_pixel(pixel)) {
    vec4 pos = imageLoad(gbuffer_position, pixel);
    if (pos.w > 0.0) {
      // Depths are positive, so their float bits order like the floats.
      uint z = floatBitsToUint(max(hier_view_depth(pos.xyz), 1e-6));
      atomicMin(group_min, z);
      atomicMax(group_max, z);
    }
  }
  barrier();
  if (gl_LocalInvocationIndex == 0u && group_max != 0u) {
    atomicMin(hier.depth.x, group_min);
    atomicMax(hier.depth.y, group_max);
  }
}
