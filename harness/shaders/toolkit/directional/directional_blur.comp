#version 460
// blur (Paper I §4.7): "for diffuse materials, we store only the irradiance in a texture, and apply
// a depth- and normal-aware blur filter to that texture. The blurred irradiance is then multiplied
// by the diffuse BRDF in the final shading stage." Paper I gives neither kernel nor weights (digest
// §4, [GAP]); this is a separable cross-bilateral filter guided by the G-buffer, run once along x
// and once along y. A tap q of pixel p weighs
//   w = exp(-k^2 / (2 sigma_s^2))                         spatial Gaussian, sigma_s = radius / 2
//     * exp(-(angle(n_p, n_q) / normal_sigma)^2)          normal awareness
//     * exp(-(dot(n_p, x_q - x_p) / (depth_sigma d_p))^2) depth awareness: distance of q from p's
//                                                         tangent plane relative to p's camera
//                                                         distance d_p (a slanted floor keeps its
//                                                         taps; a step in depth does not)
// and only diffuse samples (the ones the estimate lights) are read or written. The second (y) pass
// also applies the Lambertian BRDF: radiance = albedo / pi * E. With radius 0 one y dispatch does
// just that (the blur switched off).
#include "toolkit/constants.glsl"
#define PB_GBUFFER_BINDING 0
#include "toolkit/gbuffer.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 3, rgba32f) readonly uniform image2D source;
layout(binding = 4, rgba32f) writeonly uniform image2D target;
layout(push_constant) uniform Push {
  uint width, height;
  int radius;          // taps on each side, pixels
  uint axis;           // 0: along x, 1: along y
  float depth_sigma;   // relative: tangent-plane distance / camera distance
  float normal_sigma;  // radians
  uint apply_brdf;     // 1: write albedo / pi * blurred irradiance (the last pass)
  uint pad0;
}
push;

bool lit(ivec2 q) {
  return imageLoad(gbuffer_position, q).w > 0.0 && pb_material_lit(imageLoad(gbuffer_albedo, q).w);
}

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= int(push.width) || p.y >= int(push.height)) return;
  if (!lit(p)) {
    imageStore(target, p, vec4(0.0, 0.0, 0.0, 1.0));
    return;
  }
  vec4 xp = imageLoad(gbuffer_position, p);
  vec3 np = imageLoad(gbuffer_normal, p).xyz;
  vec3 sum = imageLoad(source, p).rgb;
  float weight = 1.0;
  if (push.radius > 0) {
    float inv_s2 = 1.0 / (2.0 * 0.25 * float(push.radius * push.radius));
    float inv_n = 1.0 / max(push.normal_sigma, 1e-6);
    float inv_d = 1.0 / max(push.depth_sigma * xp.w, 1e-9);
    ivec2 step = push.axis == 0u ? ivec2(1, 0) : ivec2(0, 1);
    ivec2 size = ivec2(push.width, push.height);
    for (int k = -push.radius; k <= push.radius; ++k) {
      ivec2 q = p + k * step;
      if (k == 0 || any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size)) || !lit(q))
        continue;
      vec3 xq = imageLoad(gbuffer_position, q).xyz;
      vec3 nq = imageLoad(gbuffer_normal, q).xyz;
      float angle = acos(clamp(dot(np, nq), -1.0, 1.0)) * inv_n;
      float plane = dot(np, xq - xp.xyz) * inv_d;
      float w = exp(-float(k * k) * inv_s2 - angle * angle - plane * plane);
      sum += w * imageLoad(source, q).rgb;
      weight += w;
    }
  }
  vec3 e = sum / weight;
  if (push.apply_brdf != 0u) e *= imageLoad(gbuffer_albedo, p).rgb / PB_PI;
  imageStore(target, p, vec4(e, 1.0));
}
