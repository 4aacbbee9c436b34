#version 460
// radiance-estimate (Paper I §4.4, toolkit/photon_gather.glsl): one invocation per pixel over this
// dispatch's slice of its tile's list, reading photons from global memory interleaved with the math
// (no shared-memory preload, as Paper I §5.1 does).
#include "tiled_common.glsl"
#include "toolkit/photon_gather.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
void main() {
  pb_gather_group_begin();
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pb_in_frame(pixel, uvec2(push.width, push.height))) {
    vec3 x, n, albedo, radiance = vec3(0.0);
    if (pb_lit_sample(pixel, x, n, albedo)) {
      uint t = (uint(pixel.y) / push.tile_size) * push.tiles_x + uint(pixel.x) / push.tile_size;
      uvec2 list = pb_list_range(t);
      uvec2 part = pb_slice_of(0u, list.y, push.list_first);
      float r2 = push.estimate_radius * push.estimate_radius;
      vec3 flux = vec3(0.0);
      uint accepted = pb_gather(list.x, part.x, part.y, x, n, r2, flux);
      pb_gather_tally(part.y - part.x, accepted);
      radiance = pb_lambert_radiance(albedo, flux, r2);
      if (push.list_first > 0u) radiance += imageLoad(indirect_out, pixel).rgb;
    }
    if (push.list_first == 0u || any(notEqual(radiance, vec3(0.0))))
      imageStore(indirect_out, pixel, vec4(radiance, 1.0));
  }
  PB_GATHER_GROUP_END(stats, TILED_STAT_READ, TILED_STAT_REJECTED);
}
