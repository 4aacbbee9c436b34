#version 460
// AAPS apply with the multisampled buffer resolved in the shader.
#define PB_MSAA
#include "aaps_apply.glsl"
