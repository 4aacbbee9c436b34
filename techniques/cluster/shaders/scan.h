// Exclusive prefix sum over push.scan_count per-node words (Paper I §4.3 uses cudpp's): SCAN_JOBS
// scans job_bins into job_offsets (regroup), SCAN_LISTS list_counts into list_offsets. Three passes:
// scan_blocks (4096 words per group: 16 per invocation, Hillis-Steele over 256 in shared memory),
// scan_top (one group over the block sums), scan_add (each block's offset added). Every loop stays far
// below llvmpipe's per-invocation loop limit up to 2^28 words.
#define SCAN_PER_THREAD 16u
#define SCAN_GROUP 256u
#define SCAN_BLOCK (SCAN_PER_THREAD * SCAN_GROUP)
uint scan_in(uint i) { return push.mode == SCAN_JOBS ? job_bins[i] : list_counts[i]; }
uint scan_out(uint i) { return push.mode == SCAN_JOBS ? job_offsets[i] : list_offsets[i]; }
void scan_store(uint i, uint v) {
  if (push.mode == SCAN_JOBS) job_offsets[i] = v; else list_offsets[i] = v;
}
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
