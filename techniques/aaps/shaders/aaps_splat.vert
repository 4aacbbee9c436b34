#version 460
// AAPS splat, vertex stage (seed 004 §1.8): a plain world-to-clip transform; the quad's
// barycentrics in [-1, 1]^2 are interpolated for the fragment stage's ellipse test.
#include "photonbench/scene_layout.h"
layout(location = 0) in vec4 in_position_bary_u;
layout(location = 1) in vec4 in_bary_v_brightness;
layout(location = 2) in uint in_photon;
layout(std430, binding = 0) readonly buffer FrameBlock { GpuFrame frame; };
layout(location = 0) out vec3 world_position;
layout(location = 1) out vec2 bary;
layout(location = 2) flat out vec3 brightness;
layout(location = 3) flat out uint photon;
void main() {
  world_position = in_position_bary_u.xyz;
  bary = vec2(in_position_bary_u.w, in_bary_v_brightness.x);
  brightness = in_bary_v_brightness.yzw;
  photon = in_photon;
  gl_Position = frame.view_projection * vec4(world_position, 1.0);
}
