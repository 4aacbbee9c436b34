// rsm-photons: one splat kernel (rsm::Kernel of rsm_core.h, 96 bytes, std430), as the splat and the
// tile gathering both read it, and the ellipsoid test of Eq. 6.5 they share.
struct Kernel {
  vec4 center;  // xyz
  vec4 axis_u;  // xyz unit axis, w half-length (m)
  vec4 axis_t;
  vec4 axis_n;
  vec4 irradiance;  // rgb: Phi / (pi |u| |t|), W/m^2
  vec4 light_dir;   // xyz: towards where the photon came from
};

// Eq. 6.5: is `point` inside the kernel's ellipsoid?
bool inside_kernel(Kernel k, vec3 point) {
  vec3 d = point - k.center.xyz;
  float a = dot(d, k.axis_u.xyz) / k.axis_u.w, b = dot(d, k.axis_t.xyz) / k.axis_t.w,
        c = dot(d, k.axis_n.xyz) / k.axis_n.w;
  return a * a + b * b + c * c <= 1.0;
}

// A point a reduced-resolution pixel tests (rsm_block.glsl; README, Deviations: half resolution):
// where the ray from the camera along `ray` meets the tangent plane of the G-buffer point `g` with
// normal `n`.
vec3 receiver_point(vec3 camera, vec3 ray, vec3 g, vec3 n) {
  float cosine = dot(ray, n);
  return abs(cosine) > 1e-3 ? camera + ray * (dot(g - camera, n) / cosine) : g;
}
