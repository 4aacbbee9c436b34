#version 460
// Radix sort, pass 3 of 3 (after the prefix sum of the counts, radix_common.glsl): each pair to
// its (digit, block) offset plus its rank among the block's keys of that digit before it.
#include "radix_common.glsl"
shared uint radix_ballot[RADIX_DIGITS * RADIX_WORDS];
void main() {
  uint id = gl_LocalInvocationID.x;
  for (uint w = id; w < RADIX_DIGITS * RADIX_WORDS; w += RADIX_GROUP) radix_ballot[w] = 0u;
  barrier();
  uint key;
  bool valid = radix_key(key);
  uint digit = radix_digit(key);
  uint word = id / 32u, bit = id % 32u;
  if (valid) atomicOr(radix_ballot[digit * RADIX_WORDS + word], 1u << bit);
  barrier();
  if (!valid) return;
  uint rank = bitCount(radix_ballot[digit * RADIX_WORDS + word] & ((1u << bit) - 1u));
  for (uint w = 0u; w < word; ++w) rank += bitCount(radix_ballot[digit * RADIX_WORDS + w]);
  uint at = radix_offsets[digit * push.blocks + gl_WorkGroupID.x] + rank;
  radix_keys_out[at] = key;
  radix_values_out[at] = radix_values_in[gl_GlobalInvocationID.x];
}
