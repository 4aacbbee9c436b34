// aaps's indirect caustics (seed 004 §5.2, indirect: splat_bvh), written once for C++ and GLSL:
// the splat record the segment walk reads, its push block and statistics words, and the splat's
// ellipse test, which the raster fragment shader (aaps_splat.glsl) and the walk's any-hit hook
// (aaps_indirect.comp) both run, so that a splat covers the same points drawn or walked. Every vec3
// is followed by a 4-byte scalar: std430 offsets equal the packed C++ ones (technique.cpp
// static_asserts them).
// GLSL: #include "../splat_bvh.h"; C++: #include "splat_bvh.h" (namespace aaps, with glm).
#ifndef AAPS_SPLAT_BVH_H
#define AAPS_SPLAT_BVH_H

#ifdef __cplusplus
#include <glm/glm.hpp>
namespace aaps {
#define AAPS_FN inline
#define AAPS_VEC2 glm::vec2
#define AAPS_VEC3 glm::vec3
#define AAPS_UINT uint32_t
#else
#define AAPS_FN
#define AAPS_VEC2 vec2
#define AAPS_VEC3 vec3
#define AAPS_UINT uint
#endif

// One accepted splat as the segment walk sees it: the quad centre +- major +- minor (the two
// principal semi-axes, orthogonal) and its brightness, the irradiance it adds where it covers a
// receiver (energy / ellipse area, §3.2.1). 64 bytes.
struct SplatRecord {
  AAPS_VEC3 centre;
  float pad0;
  AAPS_VEC3 major;
  float pad1;
  AAPS_VEC3 minor;
  float pad2;
  AAPS_VEC3 brightness;  // W/m^2 RGB
  AAPS_UINT pad3;
};

// Push block of the walk (aaps_indirect.comp).
struct IndirectPush {
  AAPS_UINT width;
  AAPS_UINT height;
  AAPS_UINT budget;    // loop steps one walk may take (llvmpipe's limit)
  float depth_margin;  // the raster depth test's relative margin (§3.3.4)
};

// Words of the walk's statistics buffer: 64-bit counts as (low, high) word pairs. WALKS: pixels
// walked (a camera path through S vertices); BOX_HITS: splat boxes the segments met (any-hit
// calls); SEGMENT_HITS: splats whose ellipse holds the segment's crossing; ELLIPSE_REJECTED:
// crossings within the depth margin in the quad, outside its ellipse; QUAD_MISSES: crossings
// within the depth margin outside the quad; NODES: BVH nodes popped; TRUNCATED (one word): walks
// cut short by the budget.
#define AAPS_STAT_WALKS 0u
#define AAPS_STAT_BOX_HITS 2u
#define AAPS_STAT_SEGMENT_HITS 4u
#define AAPS_STAT_ELLIPSE_REJECTED 6u
#define AAPS_STAT_QUAD_MISSES 8u
#define AAPS_STAT_NODES 10u
#define AAPS_STAT_TRUNCATED 12u
#define AAPS_STAT_WORDS 14u

// The quad barycentrics, in [-1, 1]^2 over the quad, of a point x on the splat's plane: the
// coordinates along the two semi-axes, as the raster pipeline interpolates them (§3.3.3).
AAPS_FN AAPS_VEC2 aaps_quad_bary(SplatRecord s, AAPS_VEC3 x) {
  AAPS_VEC3 d = x - s.centre;
  return AAPS_VEC2(dot(d, s.major) / dot(s.major, s.major),
                   dot(d, s.minor) / dot(s.minor, s.minor));
}

// §3.3.3: "when the sum of the squares of the individual barycentric coordinates is larger than
// 1, the position on the splat is outside of the ellipse, and should be discarded".
AAPS_FN bool aaps_in_ellipse(AAPS_VEC2 bary) { return !(dot(bary, bary) > 1.0f); }

// In the quad: both barycentrics in [-1, 1] (the box around a slanted quad holds more).
AAPS_FN bool aaps_in_quad(AAPS_VEC2 bary) {
  return bary.x >= -1.0f && bary.x <= 1.0f && bary.y >= -1.0f && bary.y <= 1.0f;
}

// The t at which origin + t direction crosses the splat's plane; -1 when it runs parallel.
AAPS_FN float aaps_plane_crossing(SplatRecord s, AAPS_VEC3 origin, AAPS_VEC3 direction) {
  AAPS_VEC3 n = cross(s.major, s.minor);
  float facing = dot(n, direction);
  if (facing * facing <= 1e-12f * dot(n, n)) return -1.0f;  // |cos| <= 1e-6
  return dot(s.centre - origin, n) / facing;
}

#undef AAPS_FN
#undef AAPS_VEC2
#undef AAPS_VEC3
#undef AAPS_UINT
#ifdef __cplusplus
}  // namespace aaps
#endif

#endif  // AAPS_SPLAT_BVH_H
