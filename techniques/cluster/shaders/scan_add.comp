#version 460
// splat/prefix-sum, pass 3 of 3: adds each block's offset to its words (see scan.h).
#include "cluster_common.h"
#include "scan.h"
layout(local_size_x = 256) in;
void main() {
  uint block = gl_WorkGroupID.x;
  if (block == 0u) return;
  uint begin = block * SCAN_BLOCK + gl_LocalInvocationID.x * SCAN_PER_THREAD;
  uint end = min(begin + SCAN_PER_THREAD, push.scan_count);
  uint offset = scan_blocks[block];
  for (uint i = begin; i < end; ++i) scan_store(i, scan_out(i) + offset);
}
