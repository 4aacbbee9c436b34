#version 460
// draw_scene, vertex stage: pulls the scene's world-space triangles (photonbench/scene_layout.h),
// three vertices per triangle in one draw for the whole scene, so the triangle id written is the
// record's own index and no object-to-world matrix is needed.
#include "photonbench/scene_layout.h"
layout(std430, binding = 0) readonly buffer VertexBlock { GpuSceneVertex vertices[]; };
layout(std430, binding = 1) readonly buffer TriangleBlock { GpuSceneTriangle triangles[]; };
layout(push_constant) uniform Push {
  mat4 view_projection;
  vec4 eye;  // w = 1: the eye's position; w = 0: the direction towards an eye at infinity
}
push;
layout(location = 0) out vec3 world_position;
layout(location = 1) out vec3 world_normal;
layout(location = 2) flat out uint triangle;
void main() {
  triangle = uint(gl_VertexIndex) / 3u;
  GpuSceneTriangle record = triangles[triangle];
  GpuSceneVertex vertex = vertices[record.vertices_object[uint(gl_VertexIndex) % 3u]];
  world_position = vertex.position.xyz;
  // A mesh without vertex normals shades with the face normal.
  world_normal = vertex.normal.w > 0.0 ? vertex.normal.xyz : record.normal_area.xyz;
  gl_Position = push.view_projection * vertex.position;
}
