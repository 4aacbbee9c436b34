// AAPS splat, fragment stage (seed 004 §1.8, §3.3.3-3.3.4), shared by the pixel-rate and the
// sample-rate variant (PB_PER_SAMPLE: the inputs are interpolated at each sample, so the ellipse
// and the depth test run per sample, §5.1.2).
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
layout(std430, binding = 2) buffer Contributed { uint contributed[]; };
layout(push_constant) uniform Push { float depth_margin; }
push;
layout(location = 0) out vec4 caustic;
void main() {
  // Outside the ellipse inscribed in the quad: sum of squared barycentrics above 1 (§3.3.3).
  if (dot(bary, bary) > 1.0) discard;
  // Depth against the G-buffer's camera distance with a relative margin (§3.3.4).
  float receiver = imageLoad(gbuffer_position, ivec2(gl_FragCoord.xy)).w;
  float splat = distance(frame.camera_position.xyz, world_position);
  if (receiver <= 0.0 || abs(splat - receiver) > push.depth_margin * receiver) discard;
  contributed[photon] = 1u;  // §4.5.2: the photon reached a pixel centre or sample
  caustic = vec4(brightness, 0.0);
}
