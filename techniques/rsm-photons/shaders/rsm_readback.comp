#version 460
// rsm-photons: an RGBA32F image copied into a host-visible buffer (the G-buffer and the splat
// targets, for the filters on the CPU).
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 0, rgba32f) uniform readonly image2D source;
layout(std430, binding = 1) writeonly buffer Texels { vec4 texels[]; };
layout(push_constant) uniform Push { uint width, height; }
push;
void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= int(push.width) || p.y >= int(push.height)) return;
  texels[p.y * int(push.width) + p.x] = imageLoad(source, p);
}
