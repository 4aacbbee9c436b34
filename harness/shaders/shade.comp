#version 460
// Final shading: emitted radiance seen directly (C L) + direct light (C D L) + the technique's
// indirect estimate (outgoing radiance of its path class). Background is black.
#include "photonbench/scene_layout.h"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer FrameBlock { GpuFrame frame; };
layout(std430, binding = 1) readonly buffer MaterialBlock { GpuMaterial materials[]; };
layout(binding = 2, rgba32f) readonly uniform image2D gbuffer_position;
layout(binding = 3, rgba32f) readonly uniform image2D gbuffer_normal;
layout(binding = 4, rgba32f) readonly uniform image2D direct_light;
layout(binding = 5, rgba32f) readonly uniform image2D indirect_light;
layout(binding = 6, rgba32f) writeonly uniform image2D final_out;
layout(push_constant) uniform Push { uint has_indirect; }
push;
void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pixel.x >= int(frame.size_lights.x) || pixel.y >= int(frame.size_lights.y)) return;
  vec4 pos = imageLoad(gbuffer_position, pixel);
  if (pos.w <= 0.0) {
    imageStore(final_out, pixel, vec4(0.0, 0.0, 0.0, 1.0));
    return;
  }
  GpuMaterial m = materials[uint(imageLoad(gbuffer_normal, pixel).w)];
  vec3 radiance = imageLoad(direct_light, pixel).rgb;
  if (int(m.albedo_type.w) == PB_MATERIAL_EMISSIVE) radiance += m.emission_roughness.rgb;
  if (push.has_indirect != 0u) radiance += imageLoad(indirect_light, pixel).rgb;
  imageStore(final_out, pixel, vec4(radiance, 1.0));
}
