#version 460
// Writes element 1 of each record array with every 4-byte word's index within the element, so the
// host can read each field through the C++ struct and find its offset / 4 (scene_services_test).
#include "photonbench/photon_layout.h"
#include "photonbench/scene_layout.h"
layout(local_size_x = 1) in;
layout(std430, binding = 0) writeonly buffer PhotonBlock { PhotonRecord photons[]; };
layout(std430, binding = 1) writeonly buffer VertexBlock { GpuSceneVertex vertices[]; };
layout(std430, binding = 2) writeonly buffer TriangleBlock { GpuSceneTriangle triangles[]; };
void main() {
  PhotonRecord p;
  p.position = vec3(0, 1, 2);
  p.triangle = 3u;
  p.power = vec3(4, 5, 6);
  p.path = 7u;
  p.direction = vec3(8, 9, 10);
  p.bounce = 11u;
  p.normal = vec3(12, 13, 14);
  p.specular_mask = 15u;
  p.footprint_u = vec3(16, 17, 18);
  p.light = 19u;
  p.footprint_v = vec3(20, 21, 22);
  p.flags = 23u;
  photons[1] = p;
  vertices[1] = GpuSceneVertex(vec4(0, 1, 2, 3), vec4(4, 5, 6, 7));
  triangles[1] = GpuSceneTriangle(uvec4(0, 1, 2, 3), vec4(4, 5, 6, 7), uvec4(8, 9, 10, 11));
}
