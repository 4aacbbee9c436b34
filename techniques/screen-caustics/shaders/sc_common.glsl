// screen-caustics' one binding list and push block (every pass declares all of them, so the C++
// side binds one resource list).
#include "../sc_layout.h"
#include "photonbench/scene_layout.h"

layout(std430, binding = 0) readonly buffer Photons { vec4 photons[]; };  // xyz: the hit, m
layout(std430, binding = 1) coherent buffer Counts { uint counts[]; };    // per pixel
layout(std430, binding = 2) coherent buffer Stats { uint stats[]; };
layout(std430, binding = 3) buffer CellActive { uint cell_active[]; };  // per grid cell: 0 or 1
layout(std430, binding = 4) readonly buffer ActiveCells { uint active_cells[]; };
layout(std430, binding = 5) readonly buffer FrameBlock { GpuFrame frame; };
layout(binding = 6, rgba32f) readonly uniform image2D g_position;  // xyz, w = distance (0: none)
layout(binding = 7, rgba32f) readonly uniform image2D g_normal;    // facing the camera
layout(binding = 8, rgba32f) readonly uniform image2D g_albedo;
layout(binding = 9, rgba32f) writeonly uniform image2D caustics;  // radiance, W / (m^2 sr)

layout(push_constant) uniform Push { ScPush push; };

#define SC_PI 3.14159265358979

#include "../sc_filter.h"
