// screen-caustics' push block and statistics words, written once for C++ and GLSL (every vec3
// followed by a 4-byte scalar, so std430 offsets equal the packed C++ ones; technique.cpp
// static_asserts the size). GLSL: #include "../sc_layout.h" from shaders/; C++: in namespace sc.
#ifndef SC_LAYOUT_H
#define SC_LAYOUT_H

#ifdef __cplusplus
#define SC_VEC3 glm::vec3
#define SC_UINT uint32_t
#else
#define SC_VEC3 vec3
#define SC_UINT uint
#endif

#define SC_PRECISION_8BIT 0u   // the thesis's 8-bit pbuffer: a pixel's count saturates at 255
#define SC_PRECISION_FLOAT 1u  // a float count buffer: no cap

#define SC_AREA_OFF 0u       // no pixel-area term: every pixel as if 1 m away, facing the eye
#define SC_AREA_MULTIPLY 1u  // Eq. 12.2 as printed: A = (n_s . n_e) 4 d^2 tan tan
#define SC_AREA_DIVIDE 2u    // the physical footprint: A = 4 d^2 tan tan / (n_s . n_e)

// Words of the statistics buffer (uint).
#define SC_STAT_POINTS_DRAWN 0u     // photons that passed the depth test
#define SC_STAT_POINTS_OCCLUDED 1u  // photons behind the visible surface or off screen
#define SC_STAT_WORDS 4u

// Push block of every pass. 96 bytes.
struct ScPush {
  SC_UINT width;
  SC_UINT height;
  SC_UINT photons;          // photons uploaded (all kept slots)
  SC_UINT count_precision;  // SC_PRECISION_* (GLSL reserves "precision")
  SC_UINT cell_width;       // pixels per grid cell (the last column and row may be narrower)
  SC_UINT cell_height;
  SC_UINT grid;           // cells per side
  SC_UINT area_scaling;   // SC_AREA_*
  SC_VEC3 flux;           // W (RGB): the photons' mean power (the thesis's single caustic colour)
  int k;                  // the filter's half-width (Eq. 12.1: 3)
  SC_VEC3 view_forward;   // the camera's unit view axis (d of Eq. 12.5 is depth along it)
  float weight_sum;       // sum of Eq. 12.1's weights (k = 3: 156.76)
  float pixel_tan_x;      // tan(f_x / 2) / p_x: half a pixel's width at 1 m
  float pixel_tan_y;      // tan(f_y / 2) / p_y
  float depth_tolerance;  // a point passes the depth test within this fraction of the distance
  SC_UINT tiles_per_cell_x;  // 8 x 8 filter workgroups along a cell's width
  SC_UINT tiles_per_cell_y;
  SC_UINT pad0;
  SC_UINT pad1;
  SC_UINT pad2;
};

#undef SC_VEC3
#undef SC_UINT

#endif  // SC_LAYOUT_H
