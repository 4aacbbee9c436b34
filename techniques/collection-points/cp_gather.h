// collection-points' gather rules, written once for the shaders and for C++ (tests check them on
// the CPU; the shaders run the same text): Paper V §3's cylinder and §3.1's reuse gates and weight.
// GLSL: #include "../cp_gather.h" after cp_layout.h; C++: collection_points.h includes it in
// namespace cp (with glm's dot and exp).
#ifndef CP_GATHER_H
#define CP_GATHER_H

#ifdef __cplusplus
#define CP_FN inline
#define CP_VEC3 glm::vec3
#else
#define CP_FN
#define CP_VEC3 vec3
#endif

// x lies in c's cylinder: axis n, radius r, height r / 10 centred on p (§3: "its height set to a
// tenth of c_i.r").
CP_FN bool cp_in_cylinder(CpPoint c, CP_VEC3 x) {
  CP_VEC3 d = x - c.position;
  float h = dot(d, c.normal);
  if (abs(h) > 0.05f * c.radius) return false;
  CP_VEC3 planar = d - h * c.normal;
  return dot(planar, planar) <= c.radius * c.radius;
}

// The weight last frame's CP `previous` gets in the gather at this frame's CP `current` (§3.1):
// 0 unless previous's cylinder holds current.p and Eq. 4's gates pass (|dp| <= current.r,
// n . n' >= normal_min, the same material); else Eq. 3's exp(-|dp|^2 / (2 sigma^2)) with
// sigma = sigma_scale current.r.
CP_FN float cp_reuse_weight(CpPoint previous, CpPoint current, float sigma_scale,
                            float normal_min) {
  if (!cp_in_cylinder(previous, current.position)) return 0.0f;
  CP_VEC3 d = previous.position - current.position;
  float d2 = dot(d, d);
  if (d2 > current.radius * current.radius || dot(previous.normal, current.normal) < normal_min ||
      previous.material != current.material)
    return 0.0f;
  float sigma = sigma_scale * current.radius;
  return exp(-d2 / (2.0f * sigma * sigma));
}

#undef CP_FN
#undef CP_VEC3

#endif  // CP_GATHER_H
