// illumination-maps' one binding list and push block (every pass declares all of them, so the C++
// side binds one resource list; images 6 and 7 are the hemi-plane atlas's in the gather passes and
// the camera's in the lookup).
#include "../im_layout.h"
#include "photonbench/scene_layout.h"

layout(std430, binding = 0) readonly buffer TriangleChart { uint triangle_chart[]; };
layout(std430, binding = 1) readonly buffer Charts { ImChart charts[]; };
layout(std430, binding = 2) readonly buffer Aim { vec4 aim[]; };  // rgb: AIM radiance per texel
layout(std430, binding = 3) readonly buffer Iim { vec4 iim[]; };  // rgb: displayed IIM irradiance
layout(std430, binding = 4) readonly buffer LevelIn { vec4 level_in[]; };  // MIP level read
layout(std430, binding = 5) writeonly buffer LevelOut { vec4 level_out[]; };
layout(binding = 6, rgba32f) readonly uniform image2D drawn_position;  // draw_scene's position
layout(binding = 7, r32ui) readonly uniform uimage2D drawn_triangle;   // and triangle id
layout(binding = 8, rgba32f) readonly uniform image2D g_albedo;        // the G-buffer's (lookup)
layout(binding = 9, rgba32f) writeonly uniform image2D indirect;       // radiance (lookup)

layout(push_constant) uniform Push { ImPush push; };

#include "../im_maps.h"

// The bilinear value of a per-texel array at a drawn point of triangle `t`.
#define IM_SAMPLE(values, t, p, out_rgb)                                                    \
  {                                                                                         \
    ImBilinear b_ = im_bilinear(charts[triangle_chart[t]], p);                              \
    out_rgb = b_.weight.x * values[b_.texel.x].rgb + b_.weight.y * values[b_.texel.y].rgb + \
              b_.weight.z * values[b_.texel.z].rgb + b_.weight.w * values[b_.texel.w].rgb;  \
  }
