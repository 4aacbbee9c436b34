// photon-differentials' GPU records, written once for C++ and GLSL (every vec3 followed by a
// 4-byte scalar, so std430 offsets equal the packed C++ ones; footprint.h static_asserts them).
// GLSL: #include "../pd_layout.h" from shaders/; C++: footprint.h includes it in namespace pd.
#ifndef PD_LAYOUT_H
#define PD_LAYOUT_H

#ifdef __cplusplus
#define PD_VEC3 glm::vec3
#define PD_UINT uint32_t
#else
#define PD_VEC3 vec3
#define PD_UINT uint
#endif

// One photon hit's footprint after post-processing (seed 003 §4, Fig. 1): the skewed ellipsoid
// {x : |M^-1 (x - position)| <= 1}, M = [a1 a2 h n] (semi-axes a1, a2 in the hit's plane, the
// normal extent h along the hit's normal n). 96 bytes.
struct PdFootprint {
  PD_VEC3 position;  // the hit, m
  float area;        // pi |a1 x a2|, the kernel's normalisation, m^2 (0: dropped, degenerate)
  PD_VEC3 inverse0;  // rows of M^-1, 1/m
  PD_UINT kind;      // pb::trace::PhotonKind of the photon
  PD_VEC3 inverse1;
  float radius_major;  // the longer of |a1|, |a2| after clamping, m
  PD_VEC3 inverse2;
  float radius_minor;
  PD_VEC3 flux_density;  // power / area, W/m^2 (RGB)
  PD_UINT photon;        // index of its PhotonRecord
  PD_VEC3 incoming;      // unit direction towards where the photon came from (-direction)
  float pad;
};

// The ellipsoid's axis-aligned box is the toolkit's BvhBox (photonbench/toolkit/box_bvh_layout.h):
// the toolkit's BVH (seed 003 §5.2, §6.2) is built over the boxes, in photon order.

// Words of the control buffer (uint).
#define PD_CTL_THRESHOLD 7u       // T used: nodes of at most T hits are leaves
#define PD_CTL_T_AUTO 8u          // T_auto of this frame
#define PD_CTL_INNER 9u           // inner nodes (hit count above T)
#define PD_CTL_LEAVES 10u         // leaves (runs and fused nodes) below an inner node
#define PD_CTL_AREA 11u           // sum of footprint areas, float bits, m^2
#define PD_CTL_DEGENERATE 12u     // footprints dropped (a singular ellipsoid)
#define PD_CTL_QUERIES 14u        // G-buffer samples queried
#define PD_CTL_TESTED 16u         // 2 words (64-bit): footprints tested in visited leaves
#define PD_CTL_CONTRIBUTING 18u   // 2 words: footprints containing the query point
#define PD_CTL_NODES_VISITED 20u  // 2 words: nodes whose box contained the query point
#define PD_CTL_TRUNCATED 22u      // queries cut short by the loop budget
#define PD_CTL_CLAMPED 23u        // semi-axes clamped to r_max
#define PD_CTL_NODES_FETCHED 24u  // 2 words: nodes a query read (popped), boxes tested or not
#define PD_CTL_HISTOGRAM 32u      // PD_RADIUS_BINS words: Table 3's semi-axis lengths
#define PD_CTL_WORDS 64u
#define PD_RADIUS_BINS 21u  // 0.05 m wide to 1.00 m, then "> 1.00"
#define PD_RADIUS_BIN_WIDTH 0.05

// Push block of every pass (one binding list and one push block for all of them).
struct PdPush {
  PD_UINT count;   // photons (records uploaded)
  PD_UINT groups;  // groups of the post-processing pass
  PD_UINT width;
  PD_UINT height;
  float smoothing;           // s, diffusely reflected photons
  float smoothing_specular;  // s for photons with only specular interactions (§7: 5)
  float exponent;            // nonlinear compression exponent (§4.3: -3/4)
  float r_max;               // semi-axis clamp, m
  float normal_extent;       // h / sqrt(|a1| |a2|)
  PD_UINT flags;             // PD_FLAG_*
  float surface_area;        // m^2, for T_auto
  float t_constant;          // c of T_auto = c sum A_i / A_surfaces
  PD_UINT fixed_threshold;   // > 0: T; 0: T_auto
  PD_UINT budget;            // loop iterations one invocation may take
  PD_UINT pad0;
  PD_UINT pad1;
};

#define PD_FLAG_COMPRESS_SEMIAXIS 1u  // compression factor |Delta dp|^e instead of |dp|^e
#define PD_FLAG_EPANECHNIKOV 2u
#define PD_FLAG_NORMAL_GATE 4u  // only photons arriving on the side the query normal faces

#undef PD_VEC3
#undef PD_UINT

#endif  // PD_LAYOUT_H
