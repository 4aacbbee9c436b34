#version 460
#define PB_PER_SAMPLE
#include "multisample_test_ellipse.glsl"
