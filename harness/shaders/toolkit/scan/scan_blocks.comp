#version 460
// Prefix sum, pass 1 of 3 (scan_common.glsl): each group scans its 4096 words and records their
// sum.
#include "scan_common.glsl"
void main() {
  uint begin = gl_WorkGroupID.x * SCAN_BLOCK + gl_LocalInvocationID.x * SCAN_PER_THREAD;
  uint end = min(begin + SCAN_PER_THREAD, push.count);
  uint sum = 0u;
  for (uint i = begin; i < end; ++i) sum += scan_in[i];
  uvec2 prefix = scan_group(sum);
  uint running = prefix.x;
  for (uint i = begin; i < end; ++i) {
    uint v = scan_in[i];
    scan_out[i] = running;
    running += v;
  }
  if (gl_LocalInvocationID.x == 0u) scan_blocks[gl_WorkGroupID.x] = prefix.y;
}
