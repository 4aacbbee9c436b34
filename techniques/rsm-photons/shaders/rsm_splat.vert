#version 460
// rsm-photons splat, vertex stage (seed 000 §6.2, Eq. 6.4): one instance per photon kernel, the
// proxy (an octahedron circumscribing the unit sphere) scaled along the kernel's axes u, t, n and
// moved to the photon; the proxy face's normal goes with it (inverse transpose of the same map) so
// that the fragment stage keeps one fragment per pixel (the back face).
#include "rsm_splat.glsl"
layout(location = 0) in vec4 in_vertex;       // proxy vertex in the unit frame (u, t, n)
layout(location = 1) in vec4 in_face_normal;  // its face's outward normal in the same frame
layout(location = 0) out vec3 world;
layout(location = 1) flat out vec3 face_normal;
layout(location = 2) flat out uint kernel;
void main() {
  Kernel k = kernels[gl_InstanceIndex];
  vec3 v = in_vertex.xyz, f = in_face_normal.xyz;
  world = k.center.xyz + k.axis_u.xyz * (k.axis_u.w * v.x) + k.axis_t.xyz * (k.axis_t.w * v.y) +
          k.axis_n.xyz * (k.axis_n.w * v.z);
  face_normal = k.axis_u.xyz * (f.x / k.axis_u.w) + k.axis_t.xyz * (f.y / k.axis_t.w) +
                k.axis_n.xyz * (f.z / k.axis_n.w);
  kernel = uint(gl_InstanceIndex);
  gl_Position = push.view_projection * vec4(world, 1.0);
}
