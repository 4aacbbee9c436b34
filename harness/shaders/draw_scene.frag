#version 460
// draw_scene, fragment stage: world position, shading normal facing the viewer + material index,
// and the scene-wide triangle id (pb::SceneTarget). A technique derives anything else from the
// triangle's records, as a visibility buffer is read.
#include "photonbench/scene_layout.h"
layout(std430, binding = 1) readonly buffer TriangleBlock { GpuSceneTriangle triangles[]; };
layout(push_constant) uniform Push {
  mat4 view_projection;
  vec4 eye;
}
push;
layout(location = 0) in vec3 world_position;
layout(location = 1) in vec3 world_normal;
layout(location = 2) flat in uint triangle;
layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;
layout(location = 2) out uint out_triangle;
void main() {
  vec3 to_eye = push.eye.w > 0.0 ? push.eye.xyz - world_position : push.eye.xyz;
  vec3 n = normalize(world_normal);
  // Surfaces are two-sided, as in the G-buffer: the normal faces the viewer.
  if (dot(n, to_eye) < 0.0) n = -n;
  out_position = vec4(world_position, 1.0);
  out_normal = vec4(n, float(triangles[triangle].material_local.x));
  out_triangle = triangle;
}
