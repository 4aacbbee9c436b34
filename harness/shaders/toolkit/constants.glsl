// Constants every toolkit shader shares, and the toolkit's limits (photonbench/toolkit/limits.h).
#ifndef PB_TOOLKIT_CONSTANTS_GLSL
#define PB_TOOLKIT_CONSTANTS_GLSL

#include "photonbench/toolkit/limits.h"

const float PB_PI = 3.14159265358979;
const float PB_HALF_PI = 1.57079632679490;
const float PB_INV_PI = 0.318309886183791;

#endif
