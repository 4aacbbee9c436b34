#version 460
// rsm-photons splat, fragment stage (seed 000 §6.2): the ellipsoid test (Eq. 6.5) of the pixel's
// receiver points against the kernel, then additive blending of the irradiance and the
// power-weighted light direction (w = E.r + E.g + E.b) into the two accumulation targets. Only the
// proxy's back faces count (a front face is discarded), so a pixel gets one fragment per kernel
// whether the camera is outside the proxy or inside it. The points tested lie on the ray through
// the fragment's centre, where it meets the tangent planes of the nearest and the farthest
// G-buffer pixel of the fragment's block (§6.2.1, rsm_block.glsl): at reduced resolution no
// G-buffer pixel is centred on the fragment, and a kernel smaller than a pixel (which covers the
// fragment's centre, or it would not be rasterised) would be tested a quarter pixel away from
// where it was drawn.
#include "rsm_splat.glsl"
layout(binding = 1, rgba32f) uniform readonly image2D gbuffer_position;  // w: camera distance
layout(binding = 2, rgba32f) uniform readonly image2D gbuffer_normal;
#include "rsm_block.glsl"
layout(location = 0) in vec3 world;
layout(location = 1) flat in vec3 face_normal;
layout(location = 2) flat in uint kernel;
layout(location = 0) out vec4 accumulation;  // E.rgb, w dir.x
layout(location = 1) out vec4 direction;     // w dir.y, w dir.z
void main() {
  if (dot(face_normal, world - push.camera.xyz) <= 0.0) discard;
  vec3 near_point, far_point;
  vec3 ray = normalize(world - push.camera.xyz);
  if (!block_receivers(ivec2(gl_FragCoord.xy), int(push.size.z), ivec2(push.size.xy),
                       push.camera.xyz, ray, near_point, far_point))
    discard;
  Kernel k = kernels[kernel];
  if (!inside_kernel(k, near_point) || !inside_kernel(k, far_point)) discard;
  vec3 e = k.irradiance.rgb;
  float w = e.r + e.g + e.b;
  accumulation = vec4(e, w * k.light_dir.x);
  direction = vec4(w * k.light_dir.y, w * k.light_dir.z, 0.0, 0.0);
}
