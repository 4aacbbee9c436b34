#version 460
// G-buffer pass, vertex stage: one draw per object, its object-to-world matrix pushed.
#include "photonbench/scene_layout.h"
layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(std430, binding = 0) readonly buffer FrameBlock { GpuFrame frame; };
layout(push_constant) uniform Push {
  mat4 model;
  uint material;
}
push;
layout(location = 0) out vec3 world_position;
layout(location = 1) out vec3 world_normal;
void main() {
  vec4 world = push.model * vec4(in_position, 1.0);
  world_position = world.xyz;
  world_normal = transpose(inverse(mat3(push.model))) * in_normal;
  gl_Position = frame.view_projection * world;
}
