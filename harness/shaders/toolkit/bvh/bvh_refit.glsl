// The box BVH refit's extra binding (BoxBvh::record_refit): per leaf r of the built tree its new
// bounds, words 6r .. 6r + 2 the minima and 6r + 3 .. 6r + 5 the complemented maxima, as
// order-preserving float bits (bvh_build.glsl), so both start at all ones and shrink by atomicMin.
#ifndef PB_TOOLKIT_BVH_REFIT_GLSL
#define PB_TOOLKIT_BVH_REFIT_GLSL

#include "bvh_build.glsl"

layout(std430, binding = 8) coherent buffer RefitBounds { uint refit_bounds[]; };

#endif
