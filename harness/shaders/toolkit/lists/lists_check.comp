#version 460
// splat/check: one invocation per bin compares the insert run's cursor with the count run's count
// (toolkit/photon_lists.glsl): they must agree bin for bin. Then the count becomes what an estimate
// may read: the entries both runs agree on that fit the capacity.
#define PB_LISTS_BINDING 0
#include "toolkit/photon_lists.glsl"
layout(local_size_x = 64) in;
void main() {
  uint bin = gl_GlobalInvocationID.x;
  if (bin >= pb_list_stats[PB_LIST_STAT_BINS]) return;
  uint counted = pb_list_counts[bin], inserted = pb_list_cursors[bin];
  if (counted != inserted) {
    atomicAdd(pb_list_stats[PB_LIST_STAT_MISMATCHED_BINS], 1u);
    atomicAdd(pb_list_stats[PB_LIST_STAT_MISMATCHED_ENTRIES],
              counted > inserted ? counted - inserted : inserted - counted);
  }
  uint begin = pb_list_offsets[bin], capacity = pb_list_stats[PB_LIST_STAT_CAPACITY];
  uint readable = begin < capacity ? min(min(counted, inserted), capacity - begin) : 0u;
  if (readable != counted) pb_list_counts[bin] = readable;
}
