#version 460
// splat/insert: the second splatting run, with the same tests as count, writes the photon's index
// into each touched tile's list at offsets[t] + (a per-tile cursor). Entries past the list capacity
// are dropped and counted (stats[STAT_DROPPED]): an overflow is reported, never written out of bounds.
#include "photon_layout.h"
#include "tiled_common.h"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Photons { PhotonRecord photons[]; };
layout(std430, binding = 1) readonly buffer Bounds { uint bounds[]; };
layout(std430, binding = 2) readonly buffer Offsets { uint offsets[]; };
layout(std430, binding = 3) buffer Cursors { uint cursors[]; };
layout(std430, binding = 4) writeonly buffer Lists { uint lists[]; };
layout(std430, binding = 5) buffer Stats { uint stats[]; };
#include "tiles_of_photon.h"
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.photon_count) return;
  vec3 p = photons[i].position;
  uvec2 lo, hi;
  if (!photon_tile_rect(p, lo, hi)) return;
  float z = dot(push.depth_plane.xyz, p) + push.depth_plane.w;
  uint dropped = 0u;
  for (uint ty = lo.y; ty <= hi.y; ++ty)
    for (uint tx = lo.x; tx <= hi.x; ++tx) {
      uint t = ty * push.tiles_x + tx;
      if (!tile_overlaps(t, z)) continue;
      uint slot = offsets[t] + atomicAdd(cursors[t], 1u);
      if (slot < push.capacity) lists[slot] = i; else ++dropped;
    }
  if (dropped != 0u) atomicAdd(stats[STAT_DROPPED], dropped);
}
