#version 460
// AAPS apply without MSAA.
#include "aaps_apply.glsl"
