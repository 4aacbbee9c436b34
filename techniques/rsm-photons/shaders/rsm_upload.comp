#version 460
// rsm-photons: the indirect radiance the CPU shading wrote into a host-visible buffer, copied into
// the RGBA32F image handed to the shared shade pass.
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer Texels { vec4 texels[]; };
layout(binding = 1, rgba32f) uniform writeonly image2D target;
layout(push_constant) uniform Push { uint width, height; }
push;
void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= int(push.width) || p.y >= int(push.height)) return;
  imageStore(target, p, texels[p.y * int(push.width) + p.x]);
}
