#version 460
// G-buffer pass, fragment stage: world position + view distance, shading normal facing the camera +
// material index, albedo + material type. A cleared texel (w = 0 in target 0) is background.
#include "photonbench/scene_layout.h"
layout(location = 0) in vec3 world_position;
layout(location = 1) in vec3 world_normal;
layout(std430, binding = 0) readonly buffer FrameBlock { GpuFrame frame; };
layout(std430, binding = 1) readonly buffer MaterialBlock { GpuMaterial materials[]; };
layout(push_constant) uniform Push {
  mat4 model;
  uint material;
}
push;
layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;
layout(location = 2) out vec4 out_albedo;
void main() {
  vec3 to_camera = frame.camera_position.xyz - world_position;
  vec3 n = normalize(world_normal);
  // Surfaces are two-sided for shading: the normal faces the viewer.
  if (dot(n, to_camera) < 0.0) n = -n;
  out_position = vec4(world_position, length(to_camera));
  out_normal = vec4(n, float(push.material));
  out_albedo = materials[push.material].albedo_type;
}
