#version 460
// splat/prefix-sum, pass 2 of 3: exclusive scan of the block sums in one group (see scan.h); with
// SCAN_LISTS also records the list entries wanted (stats[STAT_ENTRIES]).
#include "cluster_common.h"
#include "scan.h"
layout(local_size_x = 256) in;
void main() {
  uint blocks = (push.scan_count + SCAN_BLOCK - 1u) / SCAN_BLOCK;
  uint chunk = (blocks + SCAN_GROUP - 1u) / SCAN_GROUP;
  uint begin = min(gl_LocalInvocationID.x * chunk, blocks), end = min(begin + chunk, blocks);
  uint sum = 0u;
  for (uint b = begin; b < end; ++b) sum += scan_blocks[b];
  uvec2 prefix = scan_group(sum);
  uint running = prefix.x;
  for (uint b = begin; b < end; ++b) {
    uint v = scan_blocks[b];
    scan_blocks[b] = running;
    running += v;
  }
  if (gl_LocalInvocationID.x == 0u && push.mode == SCAN_LISTS) stats[STAT_ENTRIES] = prefix.y;
}
