#version 460
// Radix sort, pass 1 of 3 (radix_common.glsl): this block's keys per digit.
#include "radix_common.glsl"
shared uint radix_block_counts[RADIX_DIGITS];
void main() {
  uint id = gl_LocalInvocationID.x;
  if (id < RADIX_DIGITS) radix_block_counts[id] = 0u;
  barrier();
  uint key;
  if (radix_key(key)) atomicAdd(radix_block_counts[radix_digit(key)], 1u);
  barrier();
  if (id < RADIX_DIGITS) radix_counts[id * push.blocks + gl_WorkGroupID.x] = radix_block_counts[id];
}
