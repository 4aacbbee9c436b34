#version 460
// rsm-photons splat, fragment stage (seed 000 §6.2): the ellipsoid test (Eq. 6.5) of the G-buffer
// point of the pixel against the kernel, then additive blending of the irradiance and the
// power-weighted light direction (w = E.r + E.g + E.b) into the two accumulation targets. Only the
// proxy's back faces count (a front face is discarded), so a pixel gets one fragment per kernel
// whether the camera is outside the proxy or inside it. The point tested is where the ray through
// the fragment's centre meets the receiver's tangent plane (position and normal of the G-buffer
// pixel at the centre of the fragment's block): at reduced resolution no G-buffer pixel is centred
// on the fragment, and a kernel smaller than a pixel (which covers the fragment's centre, or it
// would not be rasterised) would be tested a quarter pixel away from where it was drawn.
#include "rsm_splat.glsl"
layout(binding = 1, rgba32f) uniform readonly image2D gbuffer_position;  // w: camera distance
layout(binding = 2, rgba32f) uniform readonly image2D gbuffer_normal;
layout(location = 0) in vec3 world;
layout(location = 1) flat in vec3 face_normal;
layout(location = 2) flat in uint kernel;
layout(location = 0) out vec4 accumulation;  // E.rgb, w dir.x
layout(location = 1) out vec4 direction;     // w dir.y, w dir.z
void main() {
  if (dot(face_normal, world - push.camera.xyz) <= 0.0) discard;
  int scale = int(push.size.z);
  ivec2 pixel = min(ivec2(gl_FragCoord.xy) * scale + scale / 2, ivec2(push.size.xy) - 1);
  vec4 g = imageLoad(gbuffer_position, pixel);
  if (g.w <= 0.0) discard;
  vec3 ray = normalize(world - push.camera.xyz);
  vec3 receiver = receiver_point(push.camera.xyz, ray, g.xyz, imageLoad(gbuffer_normal, pixel).xyz);
  Kernel k = kernels[kernel];
  if (!inside_kernel(k, receiver)) discard;
  vec3 e = k.irradiance.rgb;
  float w = e.r + e.g + e.b;
  accumulation = vec4(e, w * k.light_dir.x);
  direction = vec4(w * k.light_dir.y, w * k.light_dir.z, 0.0, 0.0);
}
