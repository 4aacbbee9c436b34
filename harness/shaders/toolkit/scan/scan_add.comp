#version 460
// Prefix sum, pass 3 of 3 (scan_common.glsl): adds each block's offset to its words.
#include "scan_common.glsl"
void main() {
  uint block = gl_WorkGroupID.x;
  if (block == 0u) return;
  uint begin = block * SCAN_BLOCK + gl_LocalInvocationID.x * SCAN_PER_THREAD;
  uint end = min(begin + SCAN_PER_THREAD, push.count);
  uint offset = scan_blocks[block];
  for (uint i = begin; i < end; ++i) scan_out[i] += offset;
}
