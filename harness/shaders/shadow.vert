#version 460
// Shadow-map pass: depth only, one viewport tile of the atlas per light view (cube faces or ortho).
#include "photonbench/scene_layout.h"
layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(std430, binding = 0) readonly buffer TileBlock { mat4 tiles[]; };
layout(push_constant) uniform Push {
  mat4 model;
  uint tile;
}
push;
void main() { gl_Position = tiles[push.tile] * push.model * vec4(in_position, 1.0); }
