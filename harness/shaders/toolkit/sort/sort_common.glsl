// pb::toolkit::CountingSort's kernels (photonbench/toolkit/gpu_scan.h): items (uvec2) sorted by key
// = item.y & push.key_mask into `sort_bins` bins: count per key, an exclusive prefix sum of the
// counts (PrefixSum), then a scatter to offset + cursor. Items of one key end up contiguous, in no
// particular order among themselves. The item count is read on the GPU (sort_count[push.count_at]),
// so a producer's output can be sorted without a read-back; the dispatch is indirect.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer SortIn { uvec2 sort_in[]; };
layout(std430, binding = 1) writeonly buffer SortOut { uvec2 sort_out[]; };
layout(std430, binding = 2) readonly buffer SortCount { uint sort_count[]; };
layout(std430, binding = 3) buffer SortBins { uint sort_bins[]; };  // items per key
layout(std430, binding = 4) readonly buffer SortOffsets { uint sort_offsets[]; };
layout(std430, binding = 5) buffer SortCursors { uint sort_cursors[]; };

// Mirrors CountingSort's push block (gpu_scan.cpp).
layout(push_constant) uniform SortPush {
  uint count_at;  // the item count is sort_count[count_at]
  uint key_mask;
}
push;

bool sort_item(out uvec2 item, out uint key) {
  uint i = gl_GlobalInvocationID.x;
  if (i >= sort_count[push.count_at]) return false;
  item = sort_in[i];
  key = item.y & push.key_mask;
  return true;
}
