#version 460
// AAPS splat at sample rate: `all_per_sample` and the small splats of `small_per_sample`.
#define PB_PER_SAMPLE
#include "aaps_splat.glsl"
