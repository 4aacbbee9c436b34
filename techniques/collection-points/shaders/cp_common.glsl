// collection-points' one binding list and push block (every pass declares all of them, so the C++
// side binds one resource list): bindings 0-9 the technique's buffers and images, 10-13 the walk
// of the BVH each pass walks (this frame's for the accumulation, last frame's for the reuse).
#include "../cp_layout.h"
#include "photonbench/scene_layout.h"

layout(std430, binding = 0) readonly buffer Points { CpPoint points[]; };
layout(std430, binding = 1) readonly buffer Photons { CpPhoton photons[]; };
layout(std430, binding = 2) coherent buffer Accum { uint accum[]; };
layout(std430, binding = 3) coherent buffer Stats { uint stats[]; };
layout(std430, binding = 4) readonly buffer PixelPoint { uint point_of_pixel[]; };
layout(std430, binding = 5) readonly buffer PrevPoints { CpPoint prev_points[]; };
layout(std430, binding = 6) buffer PrevRadiance { vec4 prev_radiance[]; };  // L~ of last frame
layout(std430, binding = 7) buffer Radiance { vec4 radiance[]; };  // this frame's L~ (w: reused)
layout(std430, binding = 8) readonly buffer Materials { GpuMaterial materials[]; };
layout(binding = 9, rgba32f) writeonly uniform image2D class_image;
layout(binding = 14, rgba32f) writeonly uniform image2D combined_image;

layout(push_constant) uniform Push { CpPush push; };

#define PB_BVH_WALK_BINDING 10
#include "toolkit/atomics.glsl"
#include "toolkit/bvh/bvh_walk.glsl"

#define CP_PI 3.14159265358979

#include "../cp_gather.h"
