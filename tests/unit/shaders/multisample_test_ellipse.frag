#version 460
#include "multisample_test_ellipse.glsl"
