#version 460
// Pass "gather", step 2 of Ch. 11: each hemi-plane pixel's AIM radiance (the chart of the
// triangle drawn there, bilinear at the drawn point) times Eq. 11.2's weight and the pixel count
// (the MIP map averages), stored as MIP level 0 (8bit: scaled into [0, 1] and rounded).
#include "im_common.glsl"
layout(local_size_x = 64) in;

void main() {
  uint pixels = push.hemi_size * push.hemi_size;
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.planes * pixels) return;
  uint plane = i / pixels, x = i % push.hemi_size, y = (i % pixels) / push.hemi_size;
  ivec2 at = ivec2((plane % push.planes_per_row) * push.hemi_size + x,
                   (plane / push.planes_per_row) * push.hemi_size + y);
  uint t = imageLoad(drawn_triangle, at).x;
  vec3 radiance = vec3(0.0);
  if (t != PB_NO_TRIANGLE)
    radiance = im_sample_aim(t, imageLoad(drawn_position, at).xyz, imageLoad(drawn_normal, at).xyz);
  level_out[i] = vec4(im_level0(radiance, x, y, push.hemi_size, push.half_width, push.scale_8bit,
                                push.sum_precision),
                      0.0);
}
