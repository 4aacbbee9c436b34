// pb::toolkit::PrefixSum's kernels (photonbench/toolkit/gpu_scan.h): the exclusive prefix sum of
// push.count words of `scan_in` into `scan_out`, in three passes so that no invocation loops long
// (llvmpipe's loop limit) up to 2^28 words: scan_blocks (4096 words per group: 16 per invocation, a
// Hillis-Steele scan over the group's 256 partial sums in shared memory), scan_top (one group over
// the block sums), scan_add (each block's offset added). Paper I §4.3 uses cudpp's scan here.
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer ScanIn { uint scan_in[]; };
layout(std430, binding = 1) buffer ScanOut { uint scan_out[]; };
layout(std430, binding = 2) buffer ScanBlocks { uint scan_blocks[]; };
layout(std430, binding = 3) buffer ScanTotal { uint scan_total[]; };

// Mirrors PrefixSum's push block (gpu_scan.cpp).
layout(push_constant) uniform ScanPush {
  uint count;     // words scanned
  uint total_at;  // scan_top writes the sum of all words to scan_total[total_at] (~0u: nowhere)
}
push;

#define SCAN_PER_THREAD 16u
#define SCAN_GROUP 256u
#define SCAN_BLOCK (SCAN_PER_THREAD * SCAN_GROUP)

shared uint scan_sums[SCAN_GROUP];

// Exclusive scan of one value per invocation of the group; returns (exclusive prefix, group total).
uvec2 scan_group(uint value) {
  uint id = gl_LocalInvocationID.x;
  scan_sums[id] = value;
  barrier();
  for (uint step = 1u; step < SCAN_GROUP; step <<= 1u) {
    uint add = id >= step ? scan_sums[id - step] : 0u;
    barrier();
    scan_sums[id] += add;
    barrier();
  }
  uvec2 result = uvec2(scan_sums[id] - value, scan_sums[SCAN_GROUP - 1u]);
  barrier();
  return result;
}
