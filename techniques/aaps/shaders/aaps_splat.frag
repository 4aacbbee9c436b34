#version 460
// AAPS splat at pixel rate: `none` and `all` (coverage-only MSAA, seed 004 §5.1.1).
#include "aaps_splat.glsl"
