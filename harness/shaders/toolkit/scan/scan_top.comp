#version 460
// Prefix sum, pass 2 of 3 (scan_common.glsl): one group scans the block sums in place and writes
// the total.
#include "scan_common.glsl"
void main() {
  uint blocks = (push.count + SCAN_BLOCK - 1u) / SCAN_BLOCK;
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
  if (gl_LocalInvocationID.x == 0u && push.total_at != 0xffffffffu)
    scan_total[push.total_at] = prefix.y;
}
