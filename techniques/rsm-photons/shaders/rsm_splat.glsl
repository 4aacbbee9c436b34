// rsm-photons splat: the kernel instances and the push block both stages read.
#include "rsm_kernel.glsl"
layout(std430, binding = 0) readonly buffer Kernels { Kernel kernels[]; };
layout(push_constant) uniform Push {
  mat4 view_projection;
  vec4 camera;  // xyz
  uvec4 size;   // x, y: full-resolution width, height; z: splat scale (1, 2, 4)
}
push;
