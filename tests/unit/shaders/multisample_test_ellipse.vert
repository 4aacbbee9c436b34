#version 460
// Two triangles covering the viewport, carrying quad barycentrics in [-1, 1]^2 as AAPS's splats do.
layout(location = 0) out vec2 bary;
const vec2 kCorner[6] =
    vec2[](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));
void main() {
  bary = kCorner[gl_VertexIndex % 6];
  gl_Position = vec4(bary, 0.0, 1.0);
}
