#version 460
// Counting sort, pass 3 (after the prefix sum of the counts): each item to its key's offset +
// cursor (sort_common.glsl).
#include "sort_common.glsl"
void main() {
  uvec2 item;
  uint key;
  if (sort_item(item, key)) sort_out[sort_offsets[key] + atomicAdd(sort_cursors[key], 1u)] = item;
}
