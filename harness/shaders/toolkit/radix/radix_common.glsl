// pb::toolkit::RadixSort's kernels (photonbench/toolkit/radix_sort.h): one pass of a stable LSD
// radix sort of (key, value) pairs by the 4-bit digit (key >> push.shift) & 15. radix_count writes
// each block's count of each digit, digit-major (radix_counts[digit * blocks + block]), so that
// their exclusive prefix sum (PrefixSum) is, for each (digit, block), where the block's keys of
// that digit go; radix_scatter adds each key's rank among its block's keys of the same digit and
// a lower index (ballots in shared memory: one bit per key per digit), which keeps equal digits
// in input order.
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer RadixKeysIn { uint radix_keys_in[]; };
layout(std430, binding = 1) readonly buffer RadixValuesIn { uint radix_values_in[]; };
layout(std430, binding = 2) writeonly buffer RadixKeysOut { uint radix_keys_out[]; };
layout(std430, binding = 3) writeonly buffer RadixValuesOut { uint radix_values_out[]; };
layout(std430, binding = 4) buffer RadixCounts { uint radix_counts[]; };
layout(std430, binding = 5) readonly buffer RadixOffsets { uint radix_offsets[]; };

// Mirrors RadixPush (radix_sort.cpp).
layout(push_constant) uniform RadixPush {
  uint count;   // pairs sorted
  uint shift;   // the digit's lowest bit
  uint blocks;  // groups of 256 keys
}
push;

#define RADIX_DIGITS 16u
#define RADIX_GROUP 256u
#define RADIX_WORDS (RADIX_GROUP / 32u)

// The key of this invocation and whether it is one of the sorted ones.
bool radix_key(out uint key) {
  uint i = gl_GlobalInvocationID.x;
  key = i < push.count ? radix_keys_in[i] : 0u;
  return i < push.count;
}
uint radix_digit(uint key) { return (key >> push.shift) & (RADIX_DIGITS - 1u); }
