// AAPS splat, fragment stage (seed 004 §1.8, §3.3.3-3.3.4), shared by the pixel-rate and the
// sample-rate variant (PB_PER_SAMPLE: the inputs are interpolated at each sample, so the ellipse
// and the depth test run per sample, §5.1.2).
#include "../splat_bvh.h"
#include "photonbench/scene_layout.h"
#ifdef PB_PER_SAMPLE
#define PB_INTERPOLATION sample
#else
#define PB_INTERPOLATION
#endif
layout(location = 0) PB_INTERPOLATION in vec3 world_position;
layout(location = 1) PB_INTERPOLATION in vec2 bary;
layout(location = 2) flat in vec3 brightness;
layout(location = 3) flat in uint photon;
layout(std430, binding = 0) readonly buffer FrameBlock { GpuFrame frame; };
layout(binding = 1, rgba32f) uniform readonly image2D gbuffer_position;  // w: camera distance
layout(binding = 2, rgba32f) uniform readonly image2D gbuffer_normal;
layout(std430, binding = 3) buffer Contributed { uint contributed[]; };
layout(push_constant) uniform Push { float depth_margin; }
push;
layout(location = 0) out vec4 caustic;
// Camera distance of the receiver seen along the ray from `camera` through `splat`. The G-buffer
// holds one surface point per pixel, at its centre; a sample off the centre (sample-rate shading)
// meets that surface's tangent plane instead. At the pixel centre the two agree; off it, the
// centre's own distance would be off by the depth gradient times the offset, which at grazing
// angles and low resolutions exceeds the 1% margin and dropped a third of the per-sample energy.
float receiver_distance(vec3 camera, vec3 splat, ivec2 pixel) {
  vec4 centre = imageLoad(gbuffer_position, pixel);
  if (centre.w <= 0.0) return 0.0;
  vec3 n = imageLoad(gbuffer_normal, pixel).xyz;
  vec3 ray = normalize(splat - camera);
  float cosine = dot(ray, n);
  // Grazing: the plane is met far away or not at all; keep the centre's distance.
  if (abs(cosine) < 1e-3) return centre.w;
  return dot(centre.xyz - camera, n) / cosine;
}

void main() {
  // Outside the ellipse inscribed in the quad: sum of squared barycentrics above 1 (§3.3.3).
  if (!aaps_in_ellipse(bary)) discard;
  // Depth against the receiver's camera distance with a relative margin (§3.3.4).
  vec3 camera = frame.camera_position.xyz;
  float receiver = receiver_distance(camera, world_position, ivec2(gl_FragCoord.xy));
  float splat = distance(camera, world_position);
  if (receiver <= 0.0 || abs(splat - receiver) > push.depth_margin * receiver) discard;
  contributed[photon] = 1u;  // §4.5.2: the photon reached a pixel centre or sample
  caustic = vec4(brightness, 0.0);
}
