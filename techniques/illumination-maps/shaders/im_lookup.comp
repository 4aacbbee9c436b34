#version 460
// Pass "lookup" (Ch. 11, end): each pixel's indirect radiance, the displayed IIM's irradiance at
// its point of its chart (bilinear) times albedo / pi, on diffuse surfaces; 0 elsewhere.
#include "im_common.glsl"
#define PB_INV_PI 0.318309886183791
layout(local_size_x = 8, local_size_y = 8) in;

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pixel.x >= int(push.width) || pixel.y >= int(push.height)) return;
  vec4 albedo = imageLoad(g_albedo, pixel);  // w: the material type
  uint t = imageLoad(drawn_triangle, pixel).x;
  vec3 radiance = vec3(0.0);
  if (t != PB_NO_TRIANGLE && uint(albedo.w + 0.5) == PB_MATERIAL_DIFFUSE) {
    vec3 irradiance =
        im_sample_iim(t, imageLoad(drawn_position, pixel).xyz, imageLoad(drawn_normal, pixel).xyz);
    radiance = albedo.rgb * PB_INV_PI * irradiance;
  }
  imageStore(indirect, pixel, vec4(radiance, 1.0));
}
