// Limits every photon technique works within, written once for C++ and GLSL (GLSL: `#include
// "photonbench/toolkit/limits.h"`, or through toolkit/constants.glsl).
#ifndef PB_TOOLKIT_LIMITS_H
#define PB_TOOLKIT_LIMITS_H

// llvmpipe (lavapipe) ends a shader invocation's loops after this many iterations in all, silently
// (gallivm's loop limiter, LP_MAX_TGSI_LOOP_ITERATIONS, shared by every loop of the shader; nesting
// does not help). A loop that can run longer must keep its own count and stop, counted, first.
#define PB_LLVMPIPE_LOOP_LIMIT 65535u

// Iterations a hierarchy traversal may take in one invocation (toolkit/traverse.glsl): the limit
// less room for the invocation's other loops. The `loop_budget` test hook lowers it.
#define PB_LOOP_BUDGET 60000u

// List entries one radiance-estimate invocation reads per dispatch: longer lists are read in
// slices, one dispatch each (pb::toolkit::dispatch_slices).
#define PB_LIST_SLICE 32768u

// Fixed-point flux (photonbench/toolkit/fixed_point.h, toolkit/fixed_point.glsl): the largest value
// a channel takes over the frame's photons is 2^PB_FLUX_UNIT_BITS units.
#define PB_FLUX_UNIT_BITS 26

#endif  // PB_TOOLKIT_LIMITS_H
