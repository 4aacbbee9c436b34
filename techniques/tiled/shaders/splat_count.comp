#version 460
// splat/count: one invocation per photon; counts, per tile, the photons whose sphere may touch the
// tile's samples (the first of the two splatting runs of the count / prefix-sum / insert scheme).
#include "photon_layout.h"
#include "tiled_common.h"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Photons { PhotonRecord photons[]; };
layout(std430, binding = 1) readonly buffer Bounds { uint bounds[]; };
layout(std430, binding = 2) buffer Counts { uint counts[]; };
#include "tiles_of_photon.h"
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.photon_count) return;
  vec3 p = photons[i].position;
  uvec2 lo, hi;
  if (!photon_tile_rect(p, lo, hi)) return;
  float z = dot(push.depth_plane.xyz, p) + push.depth_plane.w;
  for (uint ty = lo.y; ty <= hi.y; ++ty)
    for (uint tx = lo.x; tx <= hi.x; ++tx) {
      uint t = ty * push.tiles_x + tx;
      if (tile_overlaps(t, z)) atomicAdd(counts[t], 1u);
    }
}
