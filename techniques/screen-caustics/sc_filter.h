// screen-caustics' filter and pixel-area rules, written once for the shaders and for C++ (the tests
// check them on the CPU; the shaders run the same text): Eq. 12.1's weights, the 8-bit count's
// saturation and Eq. 12.2's pixel area. GLSL: #include "../sc_filter.h" after sc_layout.h; C++:
// screen_caustics.h includes it in namespace sc (with glm's functions).
#ifndef SC_FILTER_H
#define SC_FILTER_H

#ifdef __cplusplus
#define SC_FN inline
#define SC_UINT uint32_t
#else
#define SC_FN
#define SC_UINT uint
#endif

// Eq. 12.1's weight of the texel (i, j) away from the centre, |i|, |j| <= k: sqrt(1 + 2k^2 -
// (i^2 + j^2)), from sqrt(1 + 2k^2) at the centre down to 1 at the corners.
SC_FN float sc_weight(int i, int j, int k) { return sqrt(float(1 + 2 * k * k - (i * i + j * j))); }

// The sum of the (2k + 1)^2 weights (k = 3: 156.76, the thesis's s absorbs its inverse).
SC_FN float sc_weight_sum(int k) {
  float sum = 0.0f;
  for (int j = -k; j <= k; ++j)
    for (int i = -k; i <= k; ++i) sum += sc_weight(i, j, k);
  return sum;
}

// A pixel's photon count as the count buffer holds it: 8-bit saturates at 255 (the thesis's
// additive blending into an 8-bit pbuffer), float keeps it.
SC_FN float sc_count(SC_UINT raw, SC_UINT count_precision) {
  return count_precision == SC_PRECISION_8BIT ? float(min(raw, 255u)) : float(raw);
}

// Eq. 12.2: the world area a pixel covers at view-axis depth `depth` (d, m) on a surface whose
// normal makes cosine `cos_ne` with the direction to the eye; `pixel_tan_x` = tan(f_x / 2) / p_x
// (the thesis's tan(f_x / (2 p_x)) to first order, exact for a plane facing the view axis).
SC_FN float sc_pixel_area(SC_UINT scaling, float depth, float cos_ne, float pixel_tan_x,
                          float pixel_tan_y) {
  const float facing = 4.0f * pixel_tan_x * pixel_tan_y;
  if (scaling == SC_AREA_OFF) return facing;  // 1 m away, facing the eye
  const float area = facing * depth * depth;
  const float c = max(cos_ne, 1e-3f);
  return scaling == SC_AREA_MULTIPLY ? area * c : area / c;
}

// Irradiance (W/m^2) at a pixel whose weighted window sum of counts is `weighted_counts`
// (sum of w(i, j) t(x + i, y + j)): each count carries the mean photon flux `flux`, the window's
// weights are normalised (s = 1 / sum w), and the photons are spread over the pixel's area.
SC_FN float sc_irradiance(float weighted_counts, float weight_sum, float flux, float pixel_area) {
  return weighted_counts / weight_sum * flux / pixel_area;
}

#undef SC_FN
#undef SC_UINT

#endif  // SC_FILTER_H
