#version 460
// Pass "points" (Ch. 12 steps 1-2): each photon drawn as a point into the count buffer, depth
// tested against the visible surface (the thesis's points with additive blending onto a pbuffer
// holding the scene's depth): a compute pass, one invocation a photon, an atomic add a point.
#include "sc_common.glsl"
layout(local_size_x = 64) in;

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.photons) return;
  vec3 p = photons[i].xyz;
  vec4 clip = frame.view_projection * vec4(p, 1.0);
  bool drawn = false;
  if (clip.w > 0.0) {
    vec2 ndc = clip.xy / clip.w;
    if (all(greaterThanEqual(ndc, vec2(-1.0))) && all(lessThan(ndc, vec2(1.0)))) {
      ivec2 pixel = ivec2((ndc * 0.5 + 0.5) * vec2(push.width, push.height));
      pixel = clamp(pixel, ivec2(0), ivec2(push.width - 1u, push.height - 1u));
      vec4 g = imageLoad(g_position, pixel);
      float photon_distance = length(p - frame.camera_position.xyz);
      if (g.w > 0.0 && abs(photon_distance - g.w) <= push.depth_tolerance * g.w) {
        atomicAdd(counts[uint(pixel.y) * push.width + uint(pixel.x)], 1u);
        drawn = true;
      }
    }
  }
  atomicAdd(stats[drawn ? SC_STAT_POINTS_DRAWN : SC_STAT_POINTS_OCCLUDED], 1u);
}
