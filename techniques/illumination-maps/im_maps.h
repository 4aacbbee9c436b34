// illumination-maps' texel and hemi-plane rules, written once for the shaders and for C++ (the
// CPU passes and the tests run the same text): where a point falls in its chart's texel grid
// (bilinear), Eq. 11.2's weight of a hemi-plane pixel, and one level of the MIP-map sum with the
// thesis's 8-bit storage. GLSL: #include "../im_maps.h" after im_layout.h; C++: in namespace im
// (with glm's functions).
#ifndef IM_MAPS_H
#define IM_MAPS_H

#ifdef __cplusplus
#define IM_FN inline
#define IM_UINT uint32_t
#define IM_VEC2 glm::vec2
#define IM_VEC3 glm::vec3
#define IM_VEC4 glm::vec4
#define IM_UVEC4 glm::uvec4
#else
#define IM_FN
#define IM_UINT uint
#define IM_VEC2 vec2
#define IM_VEC3 vec3
#define IM_VEC4 vec4
#define IM_UVEC4 uvec4
#endif

#define IM_PI 3.14159265358979f

// The four texels around `p` (a point of the chart) and their bilinear weights: texel centres at
// ((i + 1/2) / texels_per_m_u, (j + 1/2) / texels_per_m_v) in the chart's uv, clamped at the grid's
// border (a point beyond the outer centres takes the border texels').
struct ImBilinear {
  IM_UVEC4 texel;  // scene-wide texel indices
  IM_VEC4 weight;  // summing to 1
};

IM_FN ImBilinear im_bilinear(ImChart c, IM_VEC3 p) {
  IM_VEC2 uv = IM_VEC2(p[(c.axis + 1u) % 3u] - c.lower_u, p[(c.axis + 2u) % 3u] - c.lower_v);
  float x = clamp(uv.x * c.texels_per_m_u - 0.5f, 0.0f, float(c.width - 1u));
  float y = clamp(uv.y * c.texels_per_m_v - 0.5f, 0.0f, float(c.height - 1u));
  IM_UINT x0 = min(IM_UINT(x), c.width - 1u), y0 = min(IM_UINT(y), c.height - 1u);
  IM_UINT x1 = min(x0 + 1u, c.width - 1u), y1 = min(y0 + 1u, c.height - 1u);
  float fx = x - float(x0), fy = y - float(y0);
  ImBilinear b;
  b.texel = IM_UVEC4(c.first_texel + y0 * c.width + x0, c.first_texel + y0 * c.width + x1,
                     c.first_texel + y1 * c.width + x0, c.first_texel + y1 * c.width + x1);
  b.weight = IM_VEC4((1.0f - fx) * (1.0f - fy), fx * (1.0f - fy), (1.0f - fx) * fy, fx * fy);
  return b;
}

// Eq. 11.2: the cosine-weighted solid angle, over pi, of hemi-plane pixel (x, y) of a
// size x size plane at height 1 with half-width `half_width`: dA / (pi (X^2 + Y^2 + 1)^2) at the
// pixel's centre (X, Y). Summed over a plane covering the whole hemisphere it would be 1.
IM_FN float im_hemi_weight(IM_UINT x, IM_UINT y, IM_UINT size, float half_width) {
  float pixel = 2.0f * half_width / float(size);
  float X = (float(x) + 0.5f) * pixel - half_width;
  float Y = (float(y) + 0.5f) * pixel - half_width;
  float d = X * X + Y * Y + 1.0f;
  return pixel * pixel / (IM_PI * d * d);
}

// A value as a level of the MIP map stores it: 8-bit (an RGBA8 level, values in [0, 1] rounded to
// n / 255) or float.
IM_FN IM_VEC3 im_store_level(IM_VEC3 v, IM_UINT sum_precision) {
  if (sum_precision != IM_SUM_8BIT) return v;
  return floor(clamp(v, IM_VEC3(0.0f), IM_VEC3(1.0f)) * 255.0f + 0.5f) / 255.0f;
}

// A hemi-plane pixel's level-0 value (Ch. 11 step 2): its radiance times Eq. 11.2's weight and the
// pixel count (the MIP map averages), 8bit: times `scale_8bit` into [0, 1], stored as a level is.
IM_FN IM_VEC3 im_level0(IM_VEC3 radiance, IM_UINT x, IM_UINT y, IM_UINT size, float half_width,
                        float scale_8bit, IM_UINT sum_precision) {
  float weight = im_hemi_weight(x, y, size, half_width) * float(size * size);
  float scale = sum_precision == IM_SUM_8BIT ? scale_8bit : 1.0f;
  return im_store_level(radiance * weight * scale, sum_precision);
}

// One MIP step: a texel of the next level is the mean of its 2 x 2 texels, stored as a level is.
IM_FN IM_VEC3 im_mip_texel(IM_VEC3 a, IM_VEC3 b, IM_VEC3 c, IM_VEC3 d, IM_UINT sum_precision) {
  return im_store_level(0.25f * (a + b + c + d), sum_precision);
}

#undef IM_FN
#undef IM_UINT
#undef IM_VEC2
#undef IM_VEC3
#undef IM_VEC4
#undef IM_UVEC4

#endif  // IM_MAPS_H
