#version 460
// splat/prefix-sum (and regroup's), pass 1 of 3: see scan.h.
#include "cluster_common.h"
#include "scan.h"
layout(local_size_x = 256) in;
void main() {
  uint begin = gl_WorkGroupID.x * SCAN_BLOCK + gl_LocalInvocationID.x * SCAN_PER_THREAD;
  uint end = min(begin + SCAN_PER_THREAD, push.scan_count);
  uint sum = 0u;
  for (uint i = begin; i < end; ++i) sum += scan_in(i);
  uvec2 prefix = scan_group(sum);
  uint running = prefix.x;
  for (uint i = begin; i < end; ++i) {
    uint v = scan_in(i);
    scan_store(i, running);
    running += v;
  }
  if (gl_LocalInvocationID.x == 0u) scan_blocks[gl_WorkGroupID.x] = prefix.y;
}
