#version 460
// Pass "resolve" (Paper V Eq. 1, §3.1 Eq. 2): per pixel with a CP, the sum I read from fixed
// point, the diffuse BSDF applied late (f = albedo / pi, the CP being a diffuse-sampled vertex),
// L_o = f I / (pi r^2); with temporal, L~ = alpha L^ + (1 - alpha) L_o where last frame gave L^,
// kept as history without the throughput; the pixel's radiance is tau L~. The class image holds
// only CPs behind at least one S vertex (C S+ D S+ L); the combined estimate all of them.
#include "cp_common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pixel.x >= int(push.width) || pixel.y >= int(push.height)) return;
  uint i = point_of_pixel[uint(pixel.y) * push.width + uint(pixel.x)];
  vec3 out_radiance = vec3(0.0);
  bool behind_specular = false;
  if (i != CP_NONE) {
    CpPoint c = points[i];
    uint at = i * CP_ACCUM_WORDS;
    vec3 flux;
    if (push.accumulator == CP_ACCUMULATOR_FIXED64) {
      for (uint k = 0u; k < 3u; ++k)
        flux[k] = pb_flux_watts(accum[at + k], accum[at + 3u + k], push.watts_per_unit[k]);
    } else {
      flux = vec3(accum[at], accum[at + 1u], accum[at + 2u]) * (1.0 / 268435456.0);
    }
    vec3 f = materials[c.material].albedo_type.rgb * float(1.0 / CP_PI);
    vec3 l = f * flux / (float(CP_PI) * c.radius * c.radius);
    if (push.temporal != 0u) {
      vec4 reused = radiance[i];
      if (reused.w > 0.0) l = push.alpha * reused.xyz + (1.0 - push.alpha) * l;
      radiance[i] = vec4(l, reused.w);
    }
    out_radiance = c.throughput * l;
    behind_specular = c.specular > 0u;
  }
  imageStore(class_image, pixel, vec4(behind_specular ? out_radiance : vec3(0.0), 1.0));
  imageStore(combined_image, pixel, vec4(out_radiance, 1.0));
}
