// AAPS apply (seed 004 §1.9), shared by both variants: the caustics buffer plus (PB_MSAA) the
// multisampled one, resolved here as the mean of its samples, is caustic irradiance E on the
// receivers; the radiance the camera sees of a diffuse receiver is
// albedo / pi * E. Also writes the irradiance's luminance for the next frame's variance (§1.10a).
#include "photonbench/scene_layout.h"
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 0, rgba32f) uniform readonly image2D caustics;
#ifdef PB_MSAA
layout(binding = 1) uniform sampler2DMS caustics_msaa;
#else
layout(binding = 1, rgba32f) uniform readonly image2D unused;
#endif
layout(binding = 2, rgba32f) uniform readonly image2D gbuffer_position;
layout(binding = 3, rgba32f) uniform readonly image2D gbuffer_albedo;
layout(binding = 4, rgba32f) uniform writeonly image2D radiance;
layout(std430, binding = 5) writeonly buffer Luminance { float luminance[]; };
layout(push_constant) uniform Push { uint width, height, samples; }
push;
void main() {
  ivec2 px = ivec2(gl_GlobalInvocationID.xy);
  if (px.x >= int(push.width) || px.y >= int(push.height)) return;
  vec3 e = imageLoad(caustics, px).rgb;
#ifdef PB_MSAA
  vec3 sum = vec3(0.0);
  for (int s = 0; s < int(push.samples); ++s) sum += texelFetch(caustics_msaa, px, s).rgb;
  e += sum / float(push.samples);
#endif
  vec4 albedo = imageLoad(gbuffer_albedo, px);
  bool lit = imageLoad(gbuffer_position, px).w > 0.0 && int(albedo.w) == PB_MATERIAL_DIFFUSE;
  vec3 l = lit ? albedo.rgb * (1.0 / 3.14159265358979) * e : vec3(0.0);
  imageStore(radiance, px, vec4(l, 1.0));
  luminance[px.y * int(push.width) + px.x] = dot(e, vec3(0.2126, 0.7152, 0.0722));
}
