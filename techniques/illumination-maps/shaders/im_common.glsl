// illumination-maps' one binding list and push block (every pass declares all of them, so the C++
// side binds one resource list; images 7 to 9 are the hemi-plane atlas's in the gather passes and
// the camera's in the lookup).
#include "../im_layout.h"
#include "photonbench/scene_layout.h"

layout(std430, binding = 0) readonly buffer TriangleChart { uint triangle_chart[]; };
layout(std430, binding = 1) readonly buffer Charts { ImChart charts[]; };
layout(std430, binding = 2) readonly buffer Aim { vec4 aim[]; };  // rgb: AIM radiance per texel
layout(std430, binding = 3) readonly buffer Iim { vec4 iim[]; };  // rgb: displayed IIM irradiance
layout(std430, binding = 4) readonly buffer LevelIn { vec4 level_in[]; };  // MIP level read
layout(std430, binding = 5) writeonly buffer LevelOut { vec4 level_out[]; };
// xyz: the texel's lit side, the normal turned towards the photons that arrive there
layout(std430, binding = 6) readonly buffer TexelNormal { vec4 texel_normal[]; };
layout(binding = 7, rgba32f) readonly uniform image2D drawn_position;  // draw_scene's position,
layout(binding = 8, rgba32f) readonly uniform image2D drawn_normal;    // normal facing the viewer
layout(binding = 9, r32ui) readonly uniform uimage2D drawn_triangle;   // and triangle id
layout(binding = 10, rgba32f) readonly uniform image2D g_albedo;       // the G-buffer's (lookup)
layout(binding = 11, rgba32f) writeonly uniform image2D indirect;      // radiance (lookup)

layout(push_constant) uniform Push { ImPush push; };

#include "../im_maps.h"

// The bilinear value of a per-texel array at a drawn point `p` of triangle `t` seen from the side
// of `n` (its normal facing the viewer): a texel counts only where its lit side faces the viewer
// (a chart's AIM belongs to the side its photons arrived on).
vec3 im_sample_aim(uint t, vec3 p, vec3 n) {
  ImBilinear b = im_bilinear(charts[triangle_chart[t]], p);
  vec3 sum = vec3(0.0);
  for (int i = 0; i < 4; ++i)
    if (dot(texel_normal[b.texel[i]].xyz, n) > 0.0) sum += b.weight[i] * aim[b.texel[i]].rgb;
  return sum;
}
vec3 im_sample_iim(uint t, vec3 p, vec3 n) {
  ImBilinear b = im_bilinear(charts[triangle_chart[t]], p);
  vec3 sum = vec3(0.0);
  for (int i = 0; i < 4; ++i)
    if (dot(texel_normal[b.texel[i]].xyz, n) > 0.0) sum += b.weight[i] * iim[b.texel[i]].rgb;
  return sum;
}
