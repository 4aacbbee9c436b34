#version 460
// splat/prefix-sum: exclusive scan of the per-tile counts into list offsets, in one work group of
// 256: each invocation sums a contiguous chunk, the 256 chunk sums are scanned in shared memory
// (Hillis-Steele), then each chunk is written out. Tile counts are small (2040 at 1080p), so one group
// suffices. Also records the total number of list entries wanted (stats[STAT_ENTRIES]).
#include "tiled_common.h"
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Counts { uint counts[]; };
layout(std430, binding = 1) writeonly buffer Offsets { uint offsets[]; };
layout(std430, binding = 2) buffer Stats { uint stats[]; };
shared uint sums[256];
void main() {
  uint id = gl_LocalInvocationID.x;
  uint chunk = (push.tile_count + 255u) / 256u;
  uint begin = min(id * chunk, push.tile_count), end = min(begin + chunk, push.tile_count);
  uint local_sum = 0u;
  for (uint t = begin; t < end; ++t) local_sum += counts[t];
  sums[id] = local_sum;
  barrier();
  for (uint step = 1u; step < 256u; step <<= 1u) {
    uint add = id >= step ? sums[id - step] : 0u;
    barrier();
    sums[id] += add;
    barrier();
  }
  uint running = sums[id] - local_sum;  // exclusive
  for (uint t = begin; t < end; ++t) {
    offsets[t] = running;
    running += counts[t];
  }
  if (id == 255u) stats[STAT_ENTRIES] = sums[255];
}
