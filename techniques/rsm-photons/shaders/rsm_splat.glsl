// rsm-photons splat: the kernel instances (rsm::Kernel of rsm_core.h, 96 bytes) and the push block
// both stages read.
struct Kernel {
  vec4 center;  // xyz
  vec4 axis_u;  // xyz unit axis, w half-length (m)
  vec4 axis_t;
  vec4 axis_n;
  vec4 irradiance;  // rgb: Phi / (pi |u| |t|), W/m^2
  vec4 light_dir;   // xyz: towards where the photon came from
};
layout(std430, binding = 0) readonly buffer Kernels { Kernel kernels[]; };
layout(push_constant) uniform Push {
  mat4 view_projection;
  vec4 camera;  // xyz
  uvec4 size;   // x, y: full-resolution width, height; z: splat scale (1, 2, 4)
}
push;
