#version 460
// Pass "gather", step 3 of Ch. 11: one MIP level, each texel the mean of the 2 x 2 below it
// (the thesis's hardware MIP-map generation), stored 8-bit or float.
#include "im_common.glsl"
layout(local_size_x = 64) in;

void main() {
  uint s = push.level_size, h = s / 2u;
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.planes * h * h) return;
  uint plane = i / (h * h), x = i % h, y = (i % (h * h)) / h;
  uint base = plane * s * s + 2u * y * s + 2u * x;
  level_out[i] =
      vec4(im_mip_texel(level_in[base].rgb, level_in[base + 1u].rgb, level_in[base + s].rgb,
                        level_in[base + s + 1u].rgb, push.sum_precision),
           0.0);
}
