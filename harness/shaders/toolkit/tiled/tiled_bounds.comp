#version 460
// tile-bounds: per-tile minimum and maximum view depth over the tile's G-buffer samples (Paper I's
// "Tiles z-Bounds", after Mara et al. 2013). One invocation per pixel; 8x8 groups reduce in shared
// memory and fold into the tile with one atomic each (tile_size is a multiple of 8, so a group lies
// in one tile). Depths are positive, so their float bits order like the floats. Background pixels
// leave the bounds empty (zmin = +inf, zmax = 0), so no photon is ever binned to an empty tile.
#include "tiled_common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
shared uint group_min, group_max;
void main() {
  if (gl_LocalInvocationIndex == 0u) {
    group_min = 0x7f800000u;
    group_max = 0u;
  }
  barrier();
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pb_in_frame(pixel, uvec2(push.width, push.height))) {
    vec4 pos = imageLoad(gbuffer_position, pixel);
    if (pos.w > 0.0) {
      float z = max(dot(push.depth_plane.xyz, pos.xyz) + push.depth_plane.w, 0.0);
      atomicMin(group_min, floatBitsToUint(z));
      atomicMax(group_max, floatBitsToUint(z));
    }
  }
  barrier();
  if (gl_LocalInvocationIndex == 0u && group_max != 0u) {
    uvec2 tile = gl_WorkGroupID.xy * 8u / push.tile_size;
    uint t = tile.y * push.tiles_x + tile.x;
    atomicMin(bounds[t], group_min);
    atomicMax(bounds[push.tile_count + t], group_max);
  }
}
