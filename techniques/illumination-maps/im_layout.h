// illumination-maps' GPU records and push block, written once for C++ and GLSL (every member a
// 4-byte scalar, so std430 offsets equal the packed C++ ones; technique.cpp static_asserts the
// sizes). GLSL: #include "../im_layout.h" from shaders/; C++: illumination_maps.h, in namespace im.
#ifndef IM_LAYOUT_H
#define IM_LAYOUT_H

#ifdef __cplusplus
#define IM_UINT uint32_t
#else
#define IM_UINT uint
#endif

#define IM_SUM_8BIT 0u   // every MIP level stored in 8 bits (the thesis's RGBA8 MIP maps, Ch. 11)
#define IM_SUM_FLOAT 1u  // float levels (the reduction by fragment programs the thesis suggests)

// One chart's illumination-map texels (AIM and IIM alike): a width x height grid over the chart's
// uv rectangle (charts.h's planar parameterisation by the dominant axis), row-major from
// first_texel. 32 bytes.
struct ImChart {
  IM_UINT axis;         // the projection axis (0 x, 1 y, 2 z): uv are the other two coordinates
  IM_UINT width;        // texels along u
  IM_UINT height;       // texels along v
  IM_UINT first_texel;  // the chart's first texel in the scene-wide texel arrays
  float lower_u;        // the chart's smallest u and v before the shift (m)
  float lower_v;
  float texels_per_m_u;  // width / the chart's u extent (0 for a chart of no extent)
  float texels_per_m_v;
};

// The push block of every pass. 64 bytes.
struct ImPush {
  IM_UINT width;  // the image the pass reads: the atlas (gather) or the frame (lookup)
  IM_UINT height;
  IM_UINT hemi_size;       // hemi-plane pixels per side (a power of two)
  IM_UINT planes_per_row;  // hemi-planes per atlas row
  IM_UINT planes;          // hemi-planes gathered in this dispatch
  IM_UINT sum_precision;   // IM_SUM_*
  IM_UINT level_size;      // reduce: the side of the level read (it writes half of it)
  IM_UINT pad0;
  float half_width;  // the hemi-plane's half-width at height 1 (Ch. 11: 2)
  float scale_8bit;  // 8bit: a level-0 value v is stored as v * scale_8bit in [0, 1]
  float weight_sum;  // the sum of Eq. 11.2's weights over the plane's pixels (its coverage)
  float pad1;
  float pad2;
  float pad3;
  float pad4;
  float pad5;
};

#undef IM_UINT

#endif  // IM_LAYOUT_H
